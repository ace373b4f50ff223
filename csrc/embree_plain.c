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

/* ---- Packets and streams -------------------------------------------------
 * The batched modes as a C program calls them: rtcIntersect8/16 and
 * rtcOccluded8/16 on W consecutive rays at a time (the last packet's unused
 * lanes marked invalid), and Embree 3's rtcIntersect1M stream. The query
 * hint is 0 or the version's own coherent flag, as the caller passes it:
 * Embree 3's context flag RTC_INTERSECT_CONTEXT_FLAG_COHERENT (1 << 0) or
 * Embree 4's argument flag RTC_RAY_QUERY_FLAG_COHERENT (1 << 16). Answers
 * go to the caller's buffers when given, as the trait's batch queries need
 * them: per ray t, u, v, primitive and geometry id (geometry
 * INVALID_ID for a miss), or 1 for a blocked ray. */

struct hybrid_hit {
  float t, u, v;
  unsigned prim, geom;
};

/* RTCIntersectArguments / RTCOccludedArguments of Embree 4.3+, as
 * rtcInitIntersectArguments fills them (all features, no context or
 * callbacks), with room for minWidthDistanceFactor. */
struct args4 {
  unsigned flags, feature_mask;
  void *context, *filter, *intersect;
  float min_width_distance_factor;
  unsigned pad;
};

#define PACKET(W)                                                                         \
  struct ray##W {                                                                         \
    float org_x[W], org_y[W], org_z[W], tnear[W], dir_x[W], dir_y[W], dir_z[W], time[W], \
        tfar[W];                                                                          \
    unsigned mask[W], id[W], flags[W];                                                    \
  } __attribute__((aligned(4 * W)));                                                      \
  struct hit3_##W {                                                                       \
    float ng_x[W], ng_y[W], ng_z[W], u[W], v[W];                                          \
    unsigned prim_id[W], geom_id[W], inst_id[1][W];                                       \
  } __attribute__((aligned(4 * W)));                                                      \
  struct hit4_##W {                                                                       \
    float ng_x[W], ng_y[W], ng_z[W], u[W], v[W];                                          \
    unsigned prim_id[W], geom_id[W], inst_id[1][W], inst_prim_id[1][W];                   \
  } __attribute__((aligned(4 * W)));                                                      \
  struct rayhit3_##W {                                                                    \
    struct ray##W ray;                                                                    \
    struct hit3_##W hit;                                                                  \
  };                                                                                      \
  struct rayhit4_##W {                                                                    \
    struct ray##W ray;                                                                    \
    struct hit4_##W hit;                                                                  \
  };                                                                                      \
  /* Lanes from ray `first` on; returns how many are valid. */                           \
  static size_t fill##W(struct ray##W *p, int *valid, const float *rays, size_t first,    \
                        size_t n) {                                                       \
    size_t live = n - first < W ? n - first : W;                                          \
    for (size_t i = 0; i < W; i++) {                                                      \
      const float *r = rays + 8 * (first + (i < live ? i : 0));                           \
      p->org_x[i] = r[0];                                                                 \
      p->org_y[i] = r[1];                                                                 \
      p->org_z[i] = r[2];                                                                 \
      p->dir_x[i] = r[3];                                                                 \
      p->dir_y[i] = r[4];                                                                 \
      p->dir_z[i] = r[5];                                                                 \
      p->tnear[i] = r[6];                                                                 \
      p->tfar[i] = r[7];                                                                  \
      p->time[i] = 0.0f;                                                                  \
      p->mask[i] = INVALID_ID;                                                            \
      p->id[i] = 0;                                                                       \
      p->flags[i] = 0;                                                                    \
      valid[i] = i < live ? -1 : 0;                                                       \
    }                                                                                     \
    return live;                                                                          \
  }

PACKET(8)
PACKET(16)

_Static_assert(sizeof(struct rayhit3_8) == 8 * 20 * 4, "RTCRayHit8 of Embree 3");
_Static_assert(sizeof(struct rayhit3_16) == 16 * 20 * 4, "RTCRayHit16 of Embree 3");
_Static_assert(sizeof(struct rayhit4_16) == 16 * 21 * 4, "RTCRayHit16 of Embree 4.3+");

/* One closest-hit function per version and width. */
#define CLOSEST(V, W, CALL)                                                               \
  static size_t closest##V##_##W(void *fn, void *scene, unsigned hint, const float *rays, \
                                 size_t n, struct hybrid_hit *out, uint64_t *checksum) {  \
    struct context3 context = {hint, NULL, {INVALID_ID}};                                 \
    struct args4 args = {hint, 0xffffffffu, NULL, NULL, NULL, 0.0f, 0};                   \
    (void)context;                                                                        \
    (void)args;                                                                           \
    size_t hits = 0;                                                                      \
    int valid[W] __attribute__((aligned(4 * W)));                                         \
    struct rayhit##V##_##W p;                                                             \
    for (size_t first = 0; first < n; first += W) {                                       \
      size_t live = fill##W(&p.ray, valid, rays, first, n);                               \
      for (size_t i = 0; i < W; i++) {                                                    \
        p.hit.geom_id[i] = INVALID_ID;                                                    \
        p.hit.prim_id[i] = INVALID_ID;                                                    \
        p.hit.inst_id[0][i] = INVALID_ID;                                                 \
      }                                                                                   \
      CALL;                                                                               \
      for (size_t i = 0; i < live; i++) {                                                 \
        unsigned geom = p.hit.geom_id[i];                                                 \
        if (geom != INVALID_ID) {                                                         \
          hits++;                                                                         \
          *checksum += p.hit.prim_id[i];                                                  \
        }                                                                                 \
        if (out) {                                                                        \
          struct hybrid_hit h = {p.ray.tfar[i], p.hit.u[i], p.hit.v[i], p.hit.prim_id[i], \
                                 geom};                                                   \
          out[first + i] = h;                                                             \
        }                                                                                 \
      }                                                                                   \
    }                                                                                     \
    return hits;                                                                          \
  }

#define OCCLUDED(V, W, CALL)                                                              \
  static size_t occluded##V##_##W(void *fn, void *scene, unsigned hint, const float *rays, \
                                  size_t n, uint8_t *out) {                               \
    struct context3 context = {hint, NULL, {INVALID_ID}};                                 \
    struct args4 args = {hint, 0xffffffffu, NULL, NULL, NULL, 0.0f, 0};                   \
    (void)context;                                                                        \
    (void)args;                                                                           \
    size_t hits = 0;                                                                      \
    int valid[W] __attribute__((aligned(4 * W)));                                         \
    struct ray##W p;                                                                      \
    for (size_t first = 0; first < n; first += W) {                                       \
      size_t live = fill##W(&p, valid, rays, first, n);                                   \
      CALL;                                                                               \
      for (size_t i = 0; i < live; i++) {                                                 \
        int blocked = p.tfar[i] < 0.0f;                                                   \
        hits += blocked;                                                                  \
        if (out) out[first + i] = (uint8_t)blocked;                                       \
      }                                                                                   \
    }                                                                                     \
    return hits;                                                                          \
  }

typedef void (*intersect3_8_fn)(const int *, void *, struct context3 *, struct rayhit3_8 *);
typedef void (*intersect3_16_fn)(const int *, void *, struct context3 *, struct rayhit3_16 *);
typedef void (*intersect4_8_fn)(const int *, void *, struct rayhit4_8 *, struct args4 *);
typedef void (*intersect4_16_fn)(const int *, void *, struct rayhit4_16 *, struct args4 *);
typedef void (*occluded3_8_fn)(const int *, void *, struct context3 *, struct ray8 *);
typedef void (*occluded3_16_fn)(const int *, void *, struct context3 *, struct ray16 *);
typedef void (*occluded4_8_fn)(const int *, void *, struct ray8 *, struct args4 *);
typedef void (*occluded4_16_fn)(const int *, void *, struct ray16 *, struct args4 *);

CLOSEST(3, 8, ((intersect3_8_fn)fn)(valid, scene, &context, &p))
CLOSEST(3, 16, ((intersect3_16_fn)fn)(valid, scene, &context, &p))
CLOSEST(4, 8, ((intersect4_8_fn)fn)(valid, scene, &p, &args))
CLOSEST(4, 16, ((intersect4_16_fn)fn)(valid, scene, &p, &args))
OCCLUDED(3, 8, ((occluded3_8_fn)fn)(valid, scene, &context, &p))
OCCLUDED(3, 16, ((occluded3_16_fn)fn)(valid, scene, &context, &p))
OCCLUDED(4, 8, ((occluded4_8_fn)fn)(valid, scene, &p, &args))
OCCLUDED(4, 16, ((occluded4_16_fn)fn)(valid, scene, &p, &args))

/* Packets of `width` (8 or 16) rays of Embree `version` (3 or 4): the
 * number of rays that hit (or are blocked); answers into `out` or
 * `blocked` when given. Returns (size_t)-1 for a width or version it does
 * not have. */
size_t hybrid_embree_packets(unsigned version, unsigned width, int occluded, void *fn,
                             void *scene, unsigned hint, const float *rays, size_t n,
                             struct hybrid_hit *out, uint8_t *blocked, uint64_t *checksum) {
  unsigned key = version * 100 + width * 2 + (occluded ? 1 : 0);
  switch (key) {
    case 316: return closest3_8(fn, scene, hint, rays, n, out, checksum);
    case 332: return closest3_16(fn, scene, hint, rays, n, out, checksum);
    case 416: return closest4_8(fn, scene, hint, rays, n, out, checksum);
    case 432: return closest4_16(fn, scene, hint, rays, n, out, checksum);
    case 317: return occluded3_8(fn, scene, hint, rays, n, blocked);
    case 333: return occluded3_16(fn, scene, hint, rays, n, blocked);
    case 417: return occluded4_8(fn, scene, hint, rays, n, blocked);
    case 433: return occluded4_16(fn, scene, hint, rays, n, blocked);
    default: return (size_t)-1;
  }
}

typedef void (*intersect3_1m_fn)(void *, struct context3 *, struct rayhit3 *, unsigned, size_t);
typedef void (*occluded3_1m_fn)(void *, struct context3 *, struct ray *, unsigned, size_t);

/* Embree 3's stream: rtcIntersect1M / rtcOccluded1M over chunks of STREAM
 * rays, with the context flag `hint`. */
#define STREAM 256
size_t hybrid_embree3_stream(int occluded, void *fn, void *scene, unsigned hint,
                             const float *rays, size_t n, struct hybrid_hit *out,
                             uint8_t *blocked, uint64_t *checksum) {
  struct context3 context = {hint, NULL, {INVALID_ID}};
  size_t hits = 0;
  static __thread struct rayhit3 chunk[STREAM];
  for (size_t first = 0; first < n; first += STREAM) {
    size_t m = n - first < STREAM ? n - first : STREAM;
    for (size_t i = 0; i < m; i++) {
      chunk[i].ray = make_ray(rays + 8 * (first + i));
      chunk[i].hit.geom_id = INVALID_ID;
      chunk[i].hit.prim_id = INVALID_ID;
      chunk[i].hit.inst_id[0] = INVALID_ID;
    }
    if (occluded) {
      /* The rays of RTCRayHit structs, at RTCRayHit's stride. */
      ((occluded3_1m_fn)fn)(scene, &context, &chunk[0].ray, (unsigned)m, sizeof(struct rayhit3));
      for (size_t i = 0; i < m; i++) {
        int b = chunk[i].ray.tfar < 0.0f;
        hits += b;
        if (blocked) blocked[first + i] = (uint8_t)b;
      }
    } else {
      ((intersect3_1m_fn)fn)(scene, &context, chunk, (unsigned)m, sizeof(struct rayhit3));
      for (size_t i = 0; i < m; i++) {
        unsigned geom = chunk[i].hit.geom_id;
        if (geom != INVALID_ID) {
          hits++;
          *checksum += chunk[i].hit.prim_id;
        }
        if (out) {
          struct hybrid_hit h = {chunk[i].ray.tfar, chunk[i].hit.u, chunk[i].hit.v,
                                 chunk[i].hit.prim_id, geom};
          out[first + i] = h;
        }
      }
    }
  }
  return hits;
}
