/* An independent replay of hybrid's exported ray sets (docs/rays.md) on
 * Embree 3 or 4, as a plain C program calls it: its own scene from
 * triangles.bin (Embree's default, medium build quality), one rtcIntersect1
 * or rtcOccluded1 per ray, Mrays/s by the thread's CPU time (median of the
 * rounds). Embree is opened with dlopen so that one source serves both
 * versions without their headers.
 *
 *   gcc -O2 -o /tmp/replay3 tools/embree_replay.c -ldl -DEMBREE_MAJOR=3
 *   taskset -c 1 /tmp/replay3 DIR /usr/lib/x86_64-linux-gnu/libembree3.so.3 [ROUNDS]
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
static void (*intersect1)();
static void (*occluded1)();

static size_t trace(void *scene, const float *r, uint64_t n, int occlusion) {
  size_t hits = 0;
  struct context ctx = {0, NULL, {INVALID}};
  for (uint64_t i = 0; i < n; i++, r += 8) {
    struct rayhit rh = {{r[0], r[1], r[2], r[6], r[3], r[4], r[5], 0, r[7], INVALID, 0, 0}};
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

#define LOAD(name) if (!(*(void **)&name = dlsym(lib, #name))) { fprintf(stderr, "no %s\n", #name); return 2; }

int main(int argc, char **argv) {
  if (argc < 3) { fprintf(stderr, "usage: %s DIR LIBEMBREE [ROUNDS]\n", argv[0]); return 2; }
  int rounds = argc > 3 ? atoi(argv[3]) : 9;
  void *lib = dlopen(argv[2], RTLD_NOW | RTLD_LOCAL);
  if (!lib) { fprintf(stderr, "%s\n", dlerror()); return 2; }
  LOAD(rtcNewDevice) LOAD(rtcNewScene) LOAD(rtcNewGeometry) LOAD(rtcSetNewGeometryBuffer)
  LOAD(rtcCommitGeometry) LOAD(rtcAttachGeometry) LOAD(rtcReleaseGeometry) LOAD(rtcCommitScene)
  if (!(*(void **)&intersect1 = dlsym(lib, "rtcIntersect1"))) return 2;
  if (!(*(void **)&occluded1 = dlsym(lib, "rtcOccluded1"))) return 2;
  char path[4096];
  uint64_t nt; uint32_t tag;
  snprintf(path, sizeof path, "%s/triangles.bin", argv[1]);
  float *tris = read_hybrid(path, "HYBTRIS1", 9, &nt, &tag);
  if (!tris) { fprintf(stderr, "%s: not a triangle file\n", path); return 2; }
  void *device = rtcNewDevice("threads=1");
  void *scene = rtcNewScene(device);
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
  const char *kinds[] = {"camera", "camera_rows", "incoherent", "shadow", "bounce", "light"};
  printf("Embree %d (%s), %llu triangles, %d rounds, Mrays/s by thread CPU time\n",
         EMBREE_MAJOR, argv[2], (unsigned long long)nt, rounds);
  for (int k = 0; k < 6; k++) {
    uint64_t n; uint32_t query;
    snprintf(path, sizeof path, "%s/%s.rays", argv[1], kinds[k]);
    float *rays = read_hybrid(path, "HYBRAYS1", 8, &n, &query);
    if (!rays) continue;
    size_t hits = trace(scene, rays, n, query == 1);
    double *t = malloc(sizeof(double) * rounds);
    for (int r = 0; r < rounds; r++) {
      double s = cpu_seconds();
      trace(scene, rays, n, query == 1);
      t[r] = cpu_seconds() - s;
    }
    qsort(t, rounds, sizeof(double), cmp);
    printf("%-12s %8llu rays %8zu hits %8.2f Mrays/s (%.2f-%.2f)\n", kinds[k],
           (unsigned long long)n, hits, n / t[rounds / 2] / 1e6, n / t[rounds - 1] / 1e6,
           n / t[0] / 1e6);
    free(t);
    free(rays);
  }
  return 0;
}
