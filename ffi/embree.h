/* The one header bindgen reads: Embree 3's public API (Debian 12's
 * libembree-dev). Embree 4's bindings come from the embree4-sys crate. */
#include <embree3/rtcore.h>
