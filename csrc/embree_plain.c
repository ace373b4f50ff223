/* Embree traced as a plain C program traces it: one rtcIntersect1 or
 * rtcOccluded1 per ray, the ray and hit structs filled in C as Embree's
 * headers lay them out, the context (Embree 3) or arguments (Embree 4) as a
 * C caller passes them. hybrid loads Embree at run time, so the functions
 * come in as pointers from the library hybrid opened; a call through them
 * costs what a call through a linked program's PLT costs.
 *
 * Rays are 8 floats each: origin xyz, direction xyz, t_min, t_max (the
 * layout of docs/rays.md). Each function returns the number of rays that
 * hit and adds their primitive ids to *checksum, so that the answers can be
 * compared with hybrid's and the loop cannot be optimised away. */

#include <stddef.h>
#include <stdint.h>

#define INVALID_ID 0xffffffffu

struct ray {
  float org_x, org_y, org_z, tnear;
  float dir_x, dir_y, dir_z, time;
  float tfar;
  unsigned mask, id, flags;
};

/* Embree 3.13: RTCHit ends with instID[1] (RTC_MAX_INSTANCE_LEVEL_COUNT 1). */
struct hit3 {
  float ng_x, ng_y, ng_z, u, v;
  unsigned prim_id, geom_id, inst_id[1];
};

/* Embree 4.3+: RTCHit also carries instPrimID[1]. */
struct hit4 {
  float ng_x, ng_y, ng_z, u, v;
  unsigned prim_id, geom_id, inst_id[1], inst_prim_id[1];
};

struct rayhit3 { struct ray ray; struct hit3 hit; } __attribute__((aligned(16)));
struct rayhit4 { struct ray ray; struct hit4 hit; } __attribute__((aligned(16)));

/* RTCIntersectContext of Embree 3 as rtcInitIntersectContext fills it. */
struct context3 {
  unsigned flags;
  void *filter;
  unsigned inst_id[1];
};

typedef void (*intersect3_fn)(void *scene, struct context3 *context, struct rayhit3 *rayhit);
typedef void (*occluded3_fn)(void *scene, struct context3 *context, struct ray *ray);
/* Embree 4: a NULL argument struct is the documented default. */
typedef void (*intersect4_fn)(void *scene, struct rayhit4 *rayhit, void *arguments);
typedef void (*occluded4_fn)(void *scene, struct ray *ray, void *arguments);

_Static_assert(sizeof(struct rayhit3) == 80, "RTCRayHit of Embree 3");
_Static_assert(sizeof(struct rayhit4) == 96, "RTCRayHit of Embree 4.3+");

static struct ray make_ray(const float *r) {
  struct ray ray = {r[0], r[1], r[2], r[6], r[3], r[4], r[5], 0.0f, r[7], INVALID_ID, 0, 0};
  return ray;
}

size_t hybrid_embree3_closest(void *fn, void *scene, const float *rays, size_t n,
                              uint64_t *checksum) {
  intersect3_fn intersect = (intersect3_fn)fn;
  struct context3 context = {0, NULL, {INVALID_ID}};
  size_t hits = 0;
  for (size_t i = 0; i < n; i++) {
    struct rayhit3 rh;
    rh.ray = make_ray(rays + 8 * i);
    rh.hit.geom_id = INVALID_ID;
    rh.hit.prim_id = INVALID_ID;
    rh.hit.inst_id[0] = INVALID_ID;
    intersect(scene, &context, &rh);
    if (rh.hit.geom_id != INVALID_ID) {
      hits++;
      *checksum += rh.hit.prim_id;
    }
  }
  return hits;
}

size_t hybrid_embree3_occluded(void *fn, void *scene, const float *rays, size_t n) {
  occluded3_fn occluded = (occluded3_fn)fn;
  struct context3 context = {0, NULL, {INVALID_ID}};
  size_t hits = 0;
  for (size_t i = 0; i < n; i++) {
    struct ray ray = make_ray(rays + 8 * i);
    occluded(scene, &context, &ray);
    hits += ray.tfar < 0.0f;
  }
  return hits;
}

size_t hybrid_embree4_closest(void *fn, void *scene, const float *rays, size_t n,
                              uint64_t *checksum) {
  intersect4_fn intersect = (intersect4_fn)fn;
  size_t hits = 0;
  for (size_t i = 0; i < n; i++) {
    struct rayhit4 rh;
    rh.ray = make_ray(rays + 8 * i);
    rh.hit.geom_id = INVALID_ID;
    rh.hit.prim_id = INVALID_ID;
    rh.hit.inst_id[0] = INVALID_ID;
    rh.hit.inst_prim_id[0] = INVALID_ID;
    intersect(scene, &rh, NULL);
    if (rh.hit.geom_id != INVALID_ID) {
      hits++;
      *checksum += rh.hit.prim_id;
    }
  }
  return hits;
}

size_t hybrid_embree4_occluded(void *fn, void *scene, const float *rays, size_t n) {
  occluded4_fn occluded = (occluded4_fn)fn;
  size_t hits = 0;
  for (size_t i = 0; i < n; i++) {
    struct ray ray = make_ray(rays + 8 * i);
    occluded(scene, &ray, NULL);
    hits += ray.tfar < 0.0f;
  }
  return hits;
}
