/* The one header bindgen reads: Embree's public API, major version chosen by
 * build.rs (Embree 3 on Debian 12, Embree 4 on Debian 13). */
#if HYBRID_EMBREE_MAJOR == 4
#include <embree4/rtcore.h>
#else
#include <embree3/rtcore.h>
#endif
