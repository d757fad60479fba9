/* bbc-scenegen: the scene model shared by its parts - the kinds and their generators
 * (kinds.c, with the meshes and surfaces they are built from), the glTF writer (gltf.c)
 * and the command line (main.c).
 * Everything here is the tool's own (no libbbc), see main.c. */
#ifndef BBC_SCENEGEN_H
#define BBC_SCENEGEN_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#define TOOL "bbc-scenegen"

static const double PI = 3.14159265358979323846;

/* main.c: exits with one line on out-of-memory: there is nothing useful the tool could do
 * instead, and saying so is better than writing a truncated scene. */
_Noreturn void die_oom(void);
void *xrealloc(void *p, size_t n);
/* Small vector algebra in double precision; geometry is rounded to float only when it
 * is stored. */

typedef struct vec3 {
  double x, y, z;
} vec3;

static inline vec3 v3(double x, double y, double z) {
  vec3 r = {x, y, z};
  return r;
}
static inline vec3 v_add(vec3 a, vec3 b) {
  return v3(a.x + b.x, a.y + b.y, a.z + b.z);
}
static inline vec3 v_sub(vec3 a, vec3 b) {
  return v3(a.x - b.x, a.y - b.y, a.z - b.z);
}
static inline vec3 v_scale(vec3 a, double s) {
  return v3(a.x * s, a.y * s, a.z * s);
}
static inline double v_dot(vec3 a, vec3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
static inline vec3 v_cross(vec3 a, vec3 b) {
  return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline vec3 v_normalize(vec3 a) {
  return v_scale(a, 1.0 / sqrt(v_dot(a, a)));
}

/* Meshes: one glTF mesh with one indexed triangle primitive each. */

typedef enum material_kind {
  MAT_DIFFUSE,
  MAT_MIRROR,
  MAT_GLASS,
  MAT_WATER,
  MAT_DIAMOND,
  MAT_EMITTER,
  MAT_DECK,
  MAT_COUNT
} material_kind;

typedef enum role { ROLE_CASTER, ROLE_RECEIVER, ROLE_NONE } role;

typedef struct mesh {
  const char *name;
  material_kind material;
  role role;
  int has_uv;
  uint32_t vertex_count, vertex_cap;
  float *positions; /* 3 per vertex */
  float *normals;   /* 3 per vertex, unit length */
  float *uvs;       /* 2 per vertex, only when has_uv */
  uint32_t triangle_count, triangle_cap;
  uint32_t *indices; /* 3 per triangle */
} mesh;

typedef enum kind {
  KIND_FLOOR,
  KIND_FLAT_MIRROR,
  KIND_WAVY_MIRROR,
  KIND_GLASS_SPHERE,
  KIND_GLASS_SLAB,
  KIND_POOL,
  KIND_TWO_MIRRORS,
  KIND_MIRROR_POOL,
  KIND_WAVY_CORNER,
  KIND_GLASS_BOX,
  KIND_WAVY_PLANE,
  KIND_GLASS_POOL,
  KIND_BALL,
  KIND_SLAB_SHEETS,
  KIND_DIAMOND,
  KIND_WIDE_POOL,
  KIND_HOLLOW_SPHERE,
  KIND_GLASS_OF_WATER,
  KIND_COUNT
} kind;

/* A scene kind: its name on the command line, the default --size, the line of --help
 * and the generator that builds it (kinds.c). */
struct scene;
typedef struct kind_info {
  const char *name;
  unsigned long default_size;
  const char *summary;
  void (*build)(struct scene *s, unsigned long size);
} kind_info;

extern const kind_info KINDS[KIND_COUNT];

typedef struct options {
  kind kind;
  const char *output;
  unsigned long size;
  int size_given;
  unsigned long width, height;
  double area_side;           /* 0: a point light */
  double sun;                 /* > 0: a directional light of this irradiance (W/m^2) instead */
  double sun_angle;           /* with sun: its angular diameter in degrees (0: a delta sun) */
  double spot;                /* > 0: a spot of this outer cone angle (radians) instead */
  unsigned long orbit;        /* 0, or the keyframes of the camera's orbit animation */
  unsigned long checker;      /* 0, or the receiver's base colour texture: a checker of N x N */
  double roughness, metallic; /* the receiver's factors (default 1 and 0: Lambertian) */
  unsigned long floor_size;   /* 0, or the floor's triangles (about): a flat grid */
  double floor_bend;          /* 0, or the height of a wave bending the floor along x */
  int glb;
} options;

typedef struct scene {
  const options *opts;
  mesh meshes[6];
  int mesh_count;
  uint32_t caster_triangles;
  vec3 light;
  double intensity; /* W/sr (glTF: candela) */
  double color[3];  /* the light's glTF color, white unless the kind says otherwise */
  vec3 eye, target, up;
  double yfov;
} scene;

/* kinds.c: the scene of o->kind, and what it owns. */
void build_scene(scene *s, const options *o);
void free_scene(scene *s);
/* The emitter's strength (radiance) of --area-light: the point light's power. */
double emissive_strength(const scene *s);

/* gltf.c: writes the scene to o->output (.gltf + .bin, or .glb) through temporary files;
 * 0, or -1 after saying why. */
int write_scene(const scene *s);

#endif
