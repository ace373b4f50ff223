/* An independent replay of hybrid's exported ray sets (docs/rays.md) on
 * tinybvh's BVH8_CPU (jbikker/tinybvh, the header-only library; not part of
 * this repository: fetch tiny_bvh.h yourself), the other in-house 8-wide BVH
 * the native backend is compared with. Its own tree from triangles.bin
 * (BVH8_CPU::Build, its default quality), one Intersect or IsOccluded per
 * ray, the Ray made inside the timed loop as a caller makes it (tinybvh
 * normalises the direction, so t_max is scaled by the direction's length;
 * it has no t_min, and every exported kind has t_min 0), Mrays/s by the
 * thread's CPU time (median of the rounds).
 *
 *   g++ -O3 -mavx2 -mfma -I DIR_OF_TINY_BVH_H -o /tmp/tinybvh_replay tools/tinybvh_replay.cpp
 *   taskset -c 1 /tmp/tinybvh_replay DIR [ROUNDS]
 */
#define TINYBVH_IMPLEMENTATION
#include "tiny_bvh.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

using tinybvh::BVH8_CPU;
using tinybvh::bvhvec3;
using tinybvh::bvhvec4;
using tinybvh::Ray;

static std::vector<float> read_hybrid(const std::string &path, const char *magic, size_t per,
                                      uint32_t *tag) {
  unsigned char h[24];
  std::vector<float> data;
  FILE *f = fopen(path.c_str(), "rb");
  if (!f) return data;
  uint64_t count = 0;
  if (fread(h, 1, 24, f) == 24 && !memcmp(h, magic, 8)) {
    memcpy(tag, h + 8, 4);
    memcpy(&count, h + 16, 8);
    data.resize(count * per);
    size_t n = fread(data.data(), sizeof(float) * per, count, f);
    if (n != count || fgetc(f) != EOF) data.clear();
  }
  fclose(f);
  return data;
}

static double cpu_seconds() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

/* Traces every ray once; returns the hits. */
static size_t trace(const BVH8_CPU &bvh, const std::vector<float> &rays, bool occlusion) {
  size_t hits = 0;
  for (size_t i = 0; i < rays.size(); i += 8) {
    const float *r = &rays[i];
    bvhvec3 o(r[0], r[1], r[2]), d(r[3], r[4], r[5]);
    float length = sqrtf(d.x * d.x + d.y * d.y + d.z * d.z);
    float t_max = std::isinf(r[7]) ? BVH_FAR : r[7] * length;
    Ray ray(o, d, t_max);
    if (occlusion) {
      hits += bvh.IsOccluded(ray);
    } else {
      bvh.Intersect(ray);
      hits += ray.hit.t < t_max;
    }
  }
  return hits;
}

int main(int argc, char **argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: tinybvh_replay DIR [ROUNDS]\n");
    return 2;
  }
  int rounds = argc > 2 ? atoi(argv[2]) : 9;
  if (rounds < 1) {
    fprintf(stderr, "tinybvh_replay: ROUNDS must be a positive whole number\n");
    return 2;
  }
  std::string dir = argv[1];
  uint32_t tag;
  std::vector<float> tris = read_hybrid(dir + "/triangles.bin", "HYBTRIS1", 9, &tag);
  if (tris.empty()) {
    fprintf(stderr, "%s/triangles.bin: not a triangle file\n", dir.c_str());
    return 2;
  }
  size_t n_tris = tris.size() / 9;
  std::vector<bvhvec4> corners(3 * n_tris);
  for (size_t i = 0; i < 3 * n_tris; i++)
    corners[i] = bvhvec4(tris[3 * i], tris[3 * i + 1], tris[3 * i + 2], 0);
  BVH8_CPU bvh;
  double start = cpu_seconds();
  bvh.Build(corners.data(), (uint32_t)n_tris);
  printf("tinybvh %d.%d.%d BVH8_CPU, %zu triangles, built in %.1f ms, %d rounds, Mrays/s by "
         "thread CPU time\n",
         TINY_BVH_VERSION_MAJOR, TINY_BVH_VERSION_MINOR, TINY_BVH_VERSION_SUB, n_tris,
         1e3 * (cpu_seconds() - start), rounds);
  const char *kinds[] = {"camera", "camera_rows", "incoherent", "shadow", "bounce", "light"};
  for (const char *kind : kinds) {
    uint32_t query;
    std::vector<float> rays = read_hybrid(dir + "/" + kind + ".rays", "HYBRAYS1", 8, &query);
    if (rays.empty()) continue;
    size_t n = rays.size() / 8, hits = trace(bvh, rays, query == 1);
    std::vector<double> t(rounds);
    for (int r = 0; r < rounds; r++) {
      double s = cpu_seconds();
      trace(bvh, rays, query == 1);
      t[r] = cpu_seconds() - s;
    }
    std::sort(t.begin(), t.end());
    printf("%-12s %8zu rays %8zu hits %8.2f Mrays/s (%.2f-%.2f)\n", kind, n, hits,
           n / t[rounds / 2] / 1e6, n / t[rounds - 1] / 1e6, n / t[0] / 1e6);
  }
  return 0;
}
