/* An independent replay of hybrid's exported ray sets (docs/rays.md) on
 * Embree 3 or 4, as a plain C program calls it: its own scene from
 * triangles.bin (Embree's default, medium build quality, unless asked),
 * one rtcIntersect1 or rtcOccluded1 per ray, Mrays/s by the thread's CPU
 * time (median of the rounds). Embree is opened with dlopen so that one
 * source serves both versions without their headers.
 *
 * The kinds of a render's waves (wave_bounce, wave_shadow) are
 * replayed too where the folder holds them. With `packets` as the fourth
 * argument it replays the camera and light rays and the waves' rays
 * (what `hybrid bench --batched` times) through rtcIntersect16 /
 * rtcOccluded16 instead, sixteen consecutive rays a call, once without a
 * hint and once with the version's coherent flag (Embree 3's context flag
 * 1, Embree 4's query flag 1 << 16), each timed alone.
 *
 * EMBREE_QUALITY=0|1|2 in the environment sets the scene's build quality
 * (low, medium, high: Embree's spatial splits) before the build.
 *
 *   gcc -O2 -o /tmp/replay3 tools/embree_replay.c -ldl -DEMBREE_MAJOR=3
 *   taskset -c 1 /tmp/replay3 DIR /usr/lib/x86_64-linux-gnu/libembree3.so.3 [ROUNDS] [packets]
 */
#include <dlfcn.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#ifndef EMBREE_MAJOR
#define EMBREE_MAJOR 3
#endif
#define INVALID 0xffffffffu

struct ray { float ox, oy, oz, tnear, dx, dy, dz, time, tfar; unsigned mask, id, flags; };
#if EMBREE_MAJOR == 3
struct hit { float nx, ny, nz, u, v; unsigned prim, geom, inst[1]; };
#else
struct hit { float nx, ny, nz, u, v; unsigned prim, geom, inst[1], inst_prim[1]; };
#endif
struct rayhit { struct ray ray; struct hit hit; } __attribute__((aligned(16)));
struct context { unsigned flags; void *filter; unsigned inst[1]; };

/* RTCRay16 and RTCHit16: one array of sixteen per field, in the order of
 * the single-ray structs. Embree 4.3+ adds instPrimID. */
struct ray16 {
  float ox[16], oy[16], oz[16], tnear[16], dx[16], dy[16], dz[16], time[16], tfar[16];
  unsigned mask[16], id[16], flags[16];
} __attribute__((aligned(64)));
struct hit16 {
  float nx[16], ny[16], nz[16], u[16], v[16];
  unsigned prim[16], geom[16], inst[16];
#if EMBREE_MAJOR == 4
  unsigned inst_prim[16];
#endif
} __attribute__((aligned(64)));
struct rayhit16 { struct ray16 ray; struct hit16 hit; };
/* Embree 4's RTCIntersectArguments / RTCOccludedArguments: flags, feature
 * mask (all), no context or callbacks; room for minWidthDistanceFactor. */
struct args4 { unsigned flags, features; void *context, *filter, *callback; float min_width; };

static float *read_hybrid(const char *path, const char *magic, size_t per, uint64_t *count,
                          uint32_t *tag) {
  unsigned char h[24];
  FILE *f = fopen(path, "rb");
  if (!f) return NULL;
  if (fread(h, 1, 24, f) != 24 || memcmp(h, magic, 8)) { fclose(f); return NULL; }
  memcpy(tag, h + 8, 4);
  memcpy(count, h + 16, 8);
  float *data = malloc(*count * per * sizeof(float) + 1);
  size_t n = data ? fread(data, sizeof(float) * per, *count, f) : 0;
  int extra = fgetc(f) != EOF;
  fclose(f);
  if (n != *count || extra) { free(data); return NULL; }
  return data;
}

static double cpu_seconds(void) {
  struct timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

static int cmp(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static void *(*rtcNewDevice)(const char *);
static void *(*rtcNewScene)(void *);
static void *(*rtcNewGeometry)(void *, int);
static void *(*rtcSetNewGeometryBuffer)(void *, int, unsigned, int, size_t, size_t);
static void (*rtcCommitGeometry)(void *);
static unsigned (*rtcAttachGeometry)(void *, void *);
static void (*rtcReleaseGeometry)(void *);
static void (*rtcCommitScene)(void *);
static void (*rtcSetSceneBuildQuality)(void *, int);
static void (*intersect1)();
static void (*occluded1)();
static void (*intersect16)();
static void (*occluded16)();

static size_t trace(void *scene, const float *r, uint64_t n, int occlusion) {
  size_t hits = 0;
  struct context ctx = {0, NULL, {INVALID}};
  for (uint64_t i = 0; i < n; i++, r += 8) {
    /* Field by field, as Embree's tutorials fill RTCRayHit: an
     * initializer would also zero the hit's other fields, stores a
     * caller need not make (they cost the cheapest rays up to 11%). */
    struct rayhit rh;
    rh.ray.ox = r[0]; rh.ray.oy = r[1]; rh.ray.oz = r[2]; rh.ray.tnear = r[6];
    rh.ray.dx = r[3]; rh.ray.dy = r[4]; rh.ray.dz = r[5]; rh.ray.time = 0;
    rh.ray.tfar = r[7]; rh.ray.mask = INVALID; rh.ray.id = 0; rh.ray.flags = 0;
    rh.hit.geom = rh.hit.prim = rh.hit.inst[0] = INVALID;
#if EMBREE_MAJOR == 3
    if (occlusion) { occluded1(scene, &ctx, &rh.ray); hits += rh.ray.tfar < 0; }
    else { intersect1(scene, &ctx, &rh); hits += rh.hit.geom != INVALID; }
#else
    (void)ctx;
    if (occlusion) { occluded1(scene, &rh.ray, NULL); hits += rh.ray.tfar < 0; }
    else { intersect1(scene, &rh, NULL); hits += rh.hit.geom != INVALID; }
#endif
  }
  return hits;
}

/* Rays `first` to `first + 16` (those past `n` invalid) into `p`. */
static void fill16(struct ray16 *p, int *valid, const float *r, uint64_t first, uint64_t n) {
  for (int i = 0; i < 16; i++) {
    uint64_t k = first + i < n ? first + i : first;
    const float *q = r + 8 * k;
    p->ox[i] = q[0]; p->oy[i] = q[1]; p->oz[i] = q[2];
    p->dx[i] = q[3]; p->dy[i] = q[4]; p->dz[i] = q[5];
    p->tnear[i] = q[6]; p->tfar[i] = q[7];
    p->time[i] = 0; p->mask[i] = INVALID; p->id[i] = 0; p->flags[i] = 0;
    valid[i] = first + i < n ? -1 : 0;
  }
}

static size_t trace16(void *scene, const float *r, uint64_t n, int occlusion, unsigned hint) {
  size_t hits = 0;
  struct context ctx = {hint, NULL, {INVALID}};
  struct args4 args = {hint, 0xffffffffu, NULL, NULL, NULL, 0.0f};
  static struct rayhit16 p;
  int valid[16] __attribute__((aligned(64)));
  for (uint64_t first = 0; first < n; first += 16) {
    fill16(&p.ray, valid, r, first, n);
#if EMBREE_MAJOR == 3
    (void)args;
    if (occlusion) occluded16(valid, scene, &ctx, &p.ray);
#else
    (void)ctx;
    if (occlusion) occluded16(valid, scene, &p.ray, &args);
#endif
    else {
      for (int i = 0; i < 16; i++) p.hit.geom[i] = p.hit.prim[i] = p.hit.inst[i] = INVALID;
#if EMBREE_MAJOR == 3
      intersect16(valid, scene, &ctx, &p);
#else
      intersect16(valid, scene, &p, &args);
#endif
    }
    for (int i = 0; i < 16 && first + i < n; i++)
      hits += occlusion ? p.ray.tfar[i] < 0 : p.hit.geom[i] != INVALID;
  }
  return hits;
}

#define LOAD(name) if (!(*(void **)&name = dlsym(lib, #name))) { fprintf(stderr, "no %s\n", #name); return 2; }

int main(int argc, char **argv) {
  if (argc < 3) { fprintf(stderr, "usage: %s DIR LIBEMBREE [ROUNDS] [packets]\n", argv[0]); return 2; }
  int rounds = argc > 3 ? atoi(argv[3]) : 9;
  int packets = argc > 4 && !strcmp(argv[4], "packets");
  if (rounds < 1) { fprintf(stderr, "ROUNDS must be a positive whole number\n"); return 2; }
  void *lib = dlopen(argv[2], RTLD_NOW | RTLD_LOCAL);
  if (!lib) { fprintf(stderr, "%s\n", dlerror()); return 2; }
  LOAD(rtcNewDevice) LOAD(rtcNewScene) LOAD(rtcNewGeometry) LOAD(rtcSetNewGeometryBuffer)
  LOAD(rtcCommitGeometry) LOAD(rtcAttachGeometry) LOAD(rtcReleaseGeometry) LOAD(rtcCommitScene)
  LOAD(rtcSetSceneBuildQuality)
  if (!(*(void **)&intersect1 = dlsym(lib, "rtcIntersect1"))) return 2;
  if (!(*(void **)&occluded1 = dlsym(lib, "rtcOccluded1"))) return 2;
  if (!(*(void **)&intersect16 = dlsym(lib, "rtcIntersect16"))) return 2;
  if (!(*(void **)&occluded16 = dlsym(lib, "rtcOccluded16"))) return 2;
  char path[4096];
  uint64_t nt; uint32_t tag;
  snprintf(path, sizeof path, "%s/triangles.bin", argv[1]);
  float *tris = read_hybrid(path, "HYBTRIS1", 9, &nt, &tag);
  if (!tris) { fprintf(stderr, "%s: not a triangle file\n", path); return 2; }
  void *device = rtcNewDevice("threads=1");
  void *scene = rtcNewScene(device);
  const char *quality = getenv("EMBREE_QUALITY");
  if (quality) {
    if (strlen(quality) != 1 || quality[0] < '0' || quality[0] > '2') {
      fprintf(stderr, "EMBREE_QUALITY must be 0, 1 or 2 (low, medium, high), not '%s'\n", quality);
      return 2;
    }
    rtcSetSceneBuildQuality(scene, quality[0] - '0');
  }
  void *geom = rtcNewGeometry(device, 0 /* TRIANGLE */);
  float *v = rtcSetNewGeometryBuffer(geom, 1 /* VERTEX */, 0, 0x9003 /* FLOAT3 */, 12, 3 * nt);
  unsigned *ix = rtcSetNewGeometryBuffer(geom, 0 /* INDEX */, 0, 0x5003 /* UINT3 */, 12, nt);
  if (!v || !ix) { fprintf(stderr, "Embree refused the buffers\n"); return 2; }
  memcpy(v, tris, nt * 36);
  for (uint64_t i = 0; i < 3 * nt; i++) ix[i] = (unsigned)i;
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(scene);
  const char *kinds[] = {"camera", "camera_rows", "incoherent", "shadow", "bounce", "light",
                         "wave_bounce", "wave_shadow"};
  const int n_kinds = sizeof kinds / sizeof kinds[0];
  printf("Embree %d (%s), %llu triangles, build quality %s, %d rounds, "
         "Mrays/s by thread CPU time\n",
         EMBREE_MAJOR, argv[2], (unsigned long long)nt, quality ? quality : "1 (default)", rounds);
  unsigned coherent = EMBREE_MAJOR == 3 ? 1u : 1u << 16;
  for (int k = 0; k < n_kinds; k++) {
    if (packets && k != 0 && k < 5) continue;
    uint64_t n; uint32_t query;
    snprintf(path, sizeof path, "%s/%s.rays", argv[1], kinds[k]);
    float *rays = read_hybrid(path, "HYBRAYS1", 8, &n, &query);
    if (!rays) continue;
    for (int mode = 0; mode < (packets ? 2 : 1); mode++) {
      unsigned hint = mode ? coherent : 0;
#define RUN() (packets ? trace16(scene, rays, n, query == 1, hint) : trace(scene, rays, n, query == 1))
      size_t hits = RUN();
      double *t = malloc(sizeof(double) * rounds);
      for (int r = 0; r < rounds; r++) {
        double s = cpu_seconds();
        RUN();
        t[r] = cpu_seconds() - s;
      }
      qsort(t, rounds, sizeof(double), cmp);
      const char *label = !packets ? "" : mode ? " packet16 hint" : " packet16";
      printf("%s%-*s %8llu rays %8zu hits %8.2f Mrays/s (%.2f-%.2f)\n", kinds[k],
             (int)(12 - strlen(kinds[k])), label, (unsigned long long)n, hits,
             n / t[rounds / 2] / 1e6, n / t[rounds - 1] / 1e6, n / t[0] / 1e6);
      free(t);
    }
    free(rays);
  }
  return 0;
}
