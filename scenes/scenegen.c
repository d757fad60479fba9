/* bbc-scenegen: writes the project's own demo and test scenes as glTF 2.0.
 *
 * The generator is deliberately standalone (C11 and libm only, no libbbc): the scenes
 * it writes are the inputs the library is tested on, so they must not be produced by
 * the code under test. It writes the glTF JSON and the binary buffer itself.
 *
 * Conventions every scene follows (the scene loader relies on them):
 *   - y is up; all geometry is written directly in world space, only the light and
 *     the camera nodes carry a transform.
 *   - asset.extras.bbc.light_units "radiometric": the light intensity is in W/sr.
 *   - Node extras {"bbc": {"role": "caster" | "receiver" | "none"}}.
 *   - Materials: diffuse = baseColor 0.8, metallic 0, roughness 1; mirror = baseColor
 *     1, metallic 1, roughness 0; glass/water = metallic 0, roughness 0 with
 *     KHR_materials_transmission 1, KHR_materials_volume thickness 1 and
 *     KHR_materials_ior.
 *   - Casters have smooth analytic vertex normals and shared vertices; receivers have
 *     NORMAL and TEXCOORD_0 spanning [0,1]. Triangles wind counter-clockwise seen from
 *     the side their normals point to.
 *   - One point light (KHR_lights_punctual) or, with --area-light, one small emissive
 *     square of the same total power facing down, or with --sun / --spot a directional
 *     or spot light aimed from the light's position at the origin; one perspective
 *     camera whose node extras hold the image size.
 *
 * The output depends only on the arguments, so repeated runs give identical bytes. */
#define _POSIX_C_SOURCE 200809L

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define TOOL "bbc-scenegen"

static const double PI = 3.14159265358979323846;

/* Limits that keep every count, index and byte offset far inside 32 bits. */
#define MAX_SIZE 10000000ul
#define MAX_IMAGE_SIDE 65536ul
#define MAX_AREA_SIDE 100.0

/* ------------------------------------------------------------------------------------ */
/* Failure handling. The tool exits on out-of-memory because there is nothing useful it
 * could do instead, and saying so is better than writing a truncated scene. */

static void die_oom(void) {
  fprintf(stderr, TOOL ": out of memory\n");
  exit(1);
}

static void *xrealloc(void *p, size_t n) {
  void *q = realloc(p, n ? n : 1);
  if (!q) die_oom();
  return q;
}

/* ------------------------------------------------------------------------------------ */
/* A growable byte buffer, used both for the JSON text and for the binary buffer. */

typedef struct bytes {
  unsigned char *data;
  size_t len, cap;
} bytes;

static void bytes_reserve(bytes *b, size_t extra) {
  if (b->len + extra <= b->cap) return;
  size_t cap = b->cap ? b->cap : 4096;
  while (cap < b->len + extra) cap *= 2;
  b->data = xrealloc(b->data, cap);
  b->cap = cap;
}

static void bytes_append(bytes *b, const void *src, size_t n) {
  bytes_reserve(b, n);
  memcpy(b->data + b->len, src, n);
  b->len += n;
}

/* Pads with the given byte to a multiple of 4, which glTF requires of every accessor
 * offset and of GLB chunks. */
static void bytes_pad4(bytes *b, unsigned char fill) {
  while (b->len % 4) bytes_append(b, &fill, 1);
}

static void bytes_printf(bytes *b, const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  va_list ap2;
  va_copy(ap2, ap);
  int n = vsnprintf(NULL, 0, fmt, ap);
  va_end(ap);
  if (n < 0) die_oom();
  bytes_reserve(b, (size_t)n + 1);
  vsnprintf((char *)b->data + b->len, (size_t)n + 1, fmt, ap2);
  va_end(ap2);
  b->len += (size_t)n;
}

/* Writes a double as the shortest of %.15g..%.17g that reads back exactly, so the JSON
 * stays readable (10, not 10.000000000000000) and loses nothing. */
static void bytes_double(bytes *b, double x) {
  char s[40];
  for (int prec = 15; prec <= 17; prec++) {
    snprintf(s, sizeof s, "%.*g", prec, x);
    if (strtod(s, NULL) == x) break;
  }
  bytes_printf(b, "%s", s);
}

/* Writes a float as it is stored in the buffer; %.9g reads back to the same float, which
 * matters for accessor min/max (validators compare them with the data exactly). */
static void bytes_float(bytes *b, float x) {
  bytes_printf(b, "%.9g", (double)x);
}

/* ------------------------------------------------------------------------------------ */
/* Small vector algebra in double precision; geometry is rounded to float only when it
 * is stored. */

typedef struct vec3 {
  double x, y, z;
} vec3;

static vec3 v3(double x, double y, double z) {
  vec3 r = {x, y, z};
  return r;
}
static vec3 v_add(vec3 a, vec3 b) {
  return v3(a.x + b.x, a.y + b.y, a.z + b.z);
}
static vec3 v_sub(vec3 a, vec3 b) {
  return v3(a.x - b.x, a.y - b.y, a.z - b.z);
}
static vec3 v_scale(vec3 a, double s) {
  return v3(a.x * s, a.y * s, a.z * s);
}
static double v_dot(vec3 a, vec3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
static vec3 v_cross(vec3 a, vec3 b) {
  return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static vec3 v_normalize(vec3 a) {
  return v_scale(a, 1.0 / sqrt(v_dot(a, a)));
}

/* ------------------------------------------------------------------------------------ */
/* Meshes: one glTF mesh with one indexed triangle primitive each. */

typedef enum material_kind {
  MAT_DIFFUSE,
  MAT_MIRROR,
  MAT_GLASS,
  MAT_WATER,
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

static mesh mesh_make(const char *name, material_kind material, role r, int has_uv) {
  mesh m;
  memset(&m, 0, sizeof m);
  m.name = name;
  m.material = material;
  m.role = r;
  m.has_uv = has_uv;
  return m;
}

static void mesh_free(mesh *m) {
  free(m->positions);
  free(m->normals);
  free(m->uvs);
  free(m->indices);
  memset(m, 0, sizeof *m);
}

static uint32_t mesh_add_vertex(mesh *m, vec3 p, vec3 n, double u, double v) {
  if (m->vertex_count == m->vertex_cap) {
    m->vertex_cap = m->vertex_cap ? 2 * m->vertex_cap : 64;
    m->positions = xrealloc(m->positions, sizeof(float) * 3 * m->vertex_cap);
    m->normals = xrealloc(m->normals, sizeof(float) * 3 * m->vertex_cap);
    if (m->has_uv) m->uvs = xrealloc(m->uvs, sizeof(float) * 2 * m->vertex_cap);
  }
  uint32_t i = m->vertex_count++;
  /* Adding +0 turns -0 into +0, so exact zeros print the same whichever way they were
   * computed (a flat wall's x = 0 * sin(...) would otherwise be -0 on half the wall). */
  n = v_normalize(n);
  p = v_add(p, v3(0, 0, 0)), n = v_add(n, v3(0, 0, 0));
  float *pp = m->positions + 3 * i, *nn = m->normals + 3 * i;
  pp[0] = (float)p.x, pp[1] = (float)p.y, pp[2] = (float)p.z;
  nn[0] = (float)n.x, nn[1] = (float)n.y, nn[2] = (float)n.z;
  if (m->has_uv) m->uvs[2 * i] = (float)u, m->uvs[2 * i + 1] = (float)v;
  return i;
}

static vec3 mesh_position(const mesh *m, uint32_t i) {
  const float *p = m->positions + 3 * i;
  return v3(p[0], p[1], p[2]);
}

static vec3 mesh_normal(const mesh *m, uint32_t i) {
  const float *n = m->normals + 3 * i;
  return v3(n[0], n[1], n[2]);
}

/* Adds a triangle, winding it counter-clockwise as seen from the side its vertex normals
 * point to. Doing this here, rather than trusting each parameterisation to have the
 * right handedness, makes the winding rule hold for every surface by construction. */
static void mesh_add_triangle(mesh *m, uint32_t a, uint32_t b, uint32_t c) {
  vec3 pa = mesh_position(m, a), pb = mesh_position(m, b), pc = mesh_position(m, c);
  vec3 g = v_cross(v_sub(pb, pa), v_sub(pc, pa));
  vec3 n = v_add(v_add(mesh_normal(m, a), mesh_normal(m, b)), mesh_normal(m, c));
  if (v_dot(g, n) < 0) {
    uint32_t t = b;
    b = c;
    c = t;
  }
  if (m->triangle_count == m->triangle_cap) {
    m->triangle_cap = m->triangle_cap ? 2 * m->triangle_cap : 64;
    m->indices = xrealloc(m->indices, sizeof(uint32_t) * 3 * m->triangle_cap);
  }
  uint32_t *t = m->indices + 3 * m->triangle_count++;
  t[0] = a, t[1] = b, t[2] = c;
}

/* A parametric surface over [0,1]^2: its point and (not necessarily unit) normal. */
typedef void (*surface_fn)(const void *params, uint32_t i, uint32_t ni, uint32_t j, uint32_t nj,
                           vec3 *p, vec3 *n);

/* Adds an ni x nj grid of quads (2 triangles each) over a surface, sharing vertices.
 * The surface gets the integer grid coordinates rather than s = i/ni so that it can
 * make boundary values exact (see slab_top). uv = (i/ni, j/nj) when the mesh has uvs. */
static void mesh_add_grid(mesh *m, uint32_t ni, uint32_t nj, surface_fn f, const void *params) {
  uint32_t base = m->vertex_count;
  for (uint32_t j = 0; j <= nj; j++) {
    for (uint32_t i = 0; i <= ni; i++) {
      vec3 p, n;
      f(params, i, ni, j, nj, &p, &n);
      mesh_add_vertex(m, p, n, (double)i / ni, (double)j / nj);
    }
  }
  for (uint32_t j = 0; j < nj; j++) {
    for (uint32_t i = 0; i < ni; i++) {
      uint32_t v00 = base + j * (ni + 1) + i, v10 = v00 + 1;
      uint32_t v01 = v00 + ni + 1, v11 = v01 + 1;
      mesh_add_triangle(m, v00, v10, v11);
      mesh_add_triangle(m, v00, v11, v01);
    }
  }
}

/* ------------------------------------------------------------------------------------ */
/* Surfaces. */

/* A horizontal rectangle [x0,x1] x [z0,z1] at height y, facing up or down. */
typedef struct plane_params {
  double x0, x1, z0, z1, y, facing;
} plane_params;

static void plane_surface(const void *params, uint32_t i, uint32_t ni, uint32_t j, uint32_t nj,
                          vec3 *p, vec3 *n) {
  const plane_params *q = params;
  double s = (double)i / ni, t = (double)j / nj;
  *p = v3(q->x0 + (q->x1 - q->x0) * s, q->y, q->z0 + (q->z1 - q->z0) * t);
  *n = v3(0, q->facing, 0);
}

/* sin(2 pi k i / n) with exact zeros where k i / n is a multiple of 1/2, so heightfields
 * that are meant to vanish on a boundary do so bit for bit and meet flat walls there
 * without a crack. */
static double sin_cycles(double k, uint32_t i, uint32_t n) {
  double x = k * (double)i / n;
  if (x * 2 == floor(x * 2)) return 0.0;
  return sin(2 * PI * x);
}

static double cos_cycles(double k, uint32_t i, uint32_t n) {
  return cos(2 * PI * k * (double)i / n);
}

/* The mirror wall x = a sin(2 pi f y) sin(2 pi f (z + 2)) over z in [-2,2], y in [0,2],
 * facing +x. With a = 0 it is the flat mirror of the analytic test. The bump pattern
 * vanishes on the wall's edges, so the wall stands exactly on the floor line x = 0. */
typedef struct wall_params {
  double amplitude, frequency;
} wall_params;

static void wall_surface(const void *params, uint32_t i, uint32_t ni, uint32_t j, uint32_t nj,
                         vec3 *p, vec3 *n) {
  const wall_params *q = params;
  double z = -2.0 + 4.0 * i / ni, y = 2.0 * j / nj;
  /* Cycles over the wall: the z side is 4 long, the y side 2. */
  double kz = 4.0 * q->frequency, ky = 2.0 * q->frequency;
  double sz = sin_cycles(kz, i, ni), sy = sin_cycles(ky, j, nj);
  double cz = cos_cycles(kz, i, ni), cy = cos_cycles(ky, j, nj);
  double w = 2 * PI * q->frequency;
  double x = q->amplitude * sy * sz;
  double dx_dy = q->amplitude * w * cy * sz, dx_dz = q->amplitude * w * sy * cz;
  *p = v3(x, y, z);
  /* The gradient of x - h(y, z), which points to +x. */
  *n = v3(1.0, -dx_dy, -dx_dz);
}

/* A rectangle origin + s du + t dv, s and t in [0,1] (du, dv and the unit normal
 * orthogonal), raised along the normal by h = bump sin(2 pi s) sin(2 pi t): flat with
 * bump 0 (the mirrors of the two-mirrors scene). The normal is the gradient of
 * (p - origin) . normal - h. */
typedef struct rect_params {
  vec3 origin, du, dv, normal;
  double bump;
} rect_params;

static void rect_surface(const void *params, uint32_t i, uint32_t ni, uint32_t j, uint32_t nj,
                         vec3 *p, vec3 *n) {
  const rect_params *q = params;
  double s = (double)i / ni, t = (double)j / nj, w = 2 * PI;
  double h = q->bump * sin_cycles(1, i, ni) * sin_cycles(1, j, nj);
  double h_s = q->bump * w * cos_cycles(1, i, ni) * sin_cycles(1, j, nj);
  double h_t = q->bump * w * sin_cycles(1, i, ni) * cos_cycles(1, j, nj);
  *p = v_add(q->origin, v_add(v_add(v_scale(q->du, s), v_scale(q->dv, t)), v_scale(q->normal, h)));
  *n = v_sub(q->normal, v_add(v_scale(q->du, h_s / v_dot(q->du, q->du)),
                              v_scale(q->dv, h_t / v_dot(q->dv, q->dv))));
}

/* The top of the glass slab: y = 0.8 + a sin(2 pi f (x + 1)) sin(2 pi f (z + 1)) over
 * [-1,1]^2, facing up. The frequency makes the bumps vanish on the edges, so the flat
 * side walls close the box exactly. */
typedef struct slab_params {
  double amplitude, frequency, height;
} slab_params;

static double slab_coord(uint32_t i, uint32_t n) {
  return -1.0 + 2.0 * i / n;
}

static void slab_top_surface(const void *params, uint32_t i, uint32_t ni, uint32_t j, uint32_t nj,
                             vec3 *p, vec3 *n) {
  const slab_params *q = params;
  double k = 2.0 * q->frequency; /* cycles across the side of length 2 */
  double sx = sin_cycles(k, i, ni), sz = sin_cycles(k, j, nj);
  double cx = cos_cycles(k, i, ni), cz = cos_cycles(k, j, nj);
  double w = 2 * PI * q->frequency;
  double y = q->height + q->amplitude * sx * sz;
  *p = v3(slab_coord(i, ni), y, slab_coord(j, nj));
  *n = v3(-q->amplitude * w * cx * sz, 1.0, -q->amplitude * w * sx * cz);
}

/* The pool's water surface: a sum of a few plane waves over [-2,2]^2, facing up. The
 * waves run in different directions so their caustics cross into the familiar net. A
 * crest of curvature k focuses light about 4/k below the water (ior 1.33), so the
 * curvatures a (2 pi / wavelength)^2 are about 1.2 to 1.5 each: the folds form just
 * above the floor 1.5 below. The wavelengths are long enough (at least 5 grid cells at
 * --size 800) for coarse test meshes to keep the pattern. */
typedef struct wave {
  double amplitude, wavelength, direction, phase;
} wave;

static const wave POOL_WAVES[] = {
    {0.08, 1.6, 0.35, 0.0},
    {0.06, 1.3, 2.2, 1.3},
    {0.045, 1.1, 4.1, 2.7},
};

static void pool_surface(const void *params, uint32_t i, uint32_t ni, uint32_t j, uint32_t nj,
                         vec3 *p, vec3 *n) {
  (void)params;
  double x = -2.0 + 4.0 * i / ni, z = -2.0 + 4.0 * j / nj;
  double y = 0, dy_dx = 0, dy_dz = 0;
  for (size_t w = 0; w < sizeof POOL_WAVES / sizeof POOL_WAVES[0]; w++) {
    const wave *q = &POOL_WAVES[w];
    double k = 2 * PI / q->wavelength;
    double dx = cos(q->direction), dz = sin(q->direction);
    double arg = k * (x * dx + z * dz) + q->phase;
    y += q->amplitude * sin(arg);
    dy_dx += q->amplitude * k * dx * cos(arg);
    dy_dz += q->amplitude * k * dz * cos(arg);
  }
  *p = v3(x, y, z);
  *n = v3(-dy_dx, 1.0, -dy_dz);
}

/* The wavy mirror plane of the shared plane scenes (the paper's Plane): z = -0.5 + h over
 * x in [0.9, 1.9], y in [0.0005, 1.0005], facing +z, h a sum of plane waves of amplitude
 * 0.02-0.03 and wavelengths 0.35-0.6 (the shared meshes' bumps have about that size). */
static const wave PLANE_WAVES[] = {
    {0.03, 0.6, 0.4, 0.0},
    {0.025, 0.45, 2.0, 1.1},
    {0.02, 0.35, 3.7, 2.3},
};

static void wavy_plane_surface(const void *params, uint32_t i, uint32_t ni, uint32_t j,
                               uint32_t nj, vec3 *p, vec3 *n) {
  (void)params;
  double x = 0.9 + (double)i / ni, y = 0.0005 + (double)j / nj;
  double z = -0.5, dz_dx = 0, dz_dy = 0;
  for (size_t w = 0; w < sizeof PLANE_WAVES / sizeof PLANE_WAVES[0]; w++) {
    const wave *q = &PLANE_WAVES[w];
    double k = 2 * PI / q->wavelength;
    double dx = cos(q->direction), dy = sin(q->direction);
    double arg = k * (x * dx + y * dy) + q->phase;
    z += q->amplitude * sin(arg);
    dz_dx += q->amplitude * k * dx * cos(arg);
    dz_dy += q->amplitude * k * dy * cos(arg);
  }
  *p = v3(x, y, z);
  *n = v3(-dz_dx, -dz_dy, 1.0);
}

/* ------------------------------------------------------------------------------------ */
/* Tessellation counts. Each picks the grid closest to the requested triangle count. */

static uint32_t round_at_least_1(double x) {
  return x < 1.5 ? 1u : (uint32_t)(x + 0.5);
}

/* A square grid of n x n quads, 2 n^2 triangles. */
static uint32_t square_grid_side(unsigned long size) {
  return round_at_least_1(sqrt(size / 2.0));
}

/* The mirror wall is twice as wide (z) as it is high (y); its cells stay about square. */
static void wall_grid(unsigned long size, uint32_t *nz, uint32_t *ny) {
  *ny = round_at_least_1(sqrt(size / 4.0));
  *nz = round_at_least_1(size / (2.0 * *ny));
}

/* The slab: an n x n top, 4 side walls of n + 1 triangles and a 2-triangle bottom. */
static uint32_t slab_count(uint32_t n) {
  return 2 * n * n + 4 * (n + 1) + 2;
}

static uint32_t slab_grid_side(unsigned long size) {
  uint32_t best = 1;
  for (uint32_t n = 1; slab_count(n) <= 4 * size + 16; n++) {
    if (labs((long)slab_count(n) - (long)size) < labs((long)slab_count(best) - (long)size))
      best = n;
  }
  return best;
}

/* The sphere: an icosahedron whose faces are each split into n^2 triangles. */
static uint32_t sphere_frequency(unsigned long size) {
  return round_at_least_1(sqrt(size / 20.0));
}

/* ------------------------------------------------------------------------------------ */
/* Meshes of each kind. */

static void add_plane(mesh *m, double x0, double x1, double z0, double z1, double y, double facing,
                      uint32_t n) {
  plane_params q = {x0, x1, z0, z1, y, facing};
  mesh_add_grid(m, n, n, plane_surface, &q);
}

/* The closed slab: wavy top, four flat sides, flat bottom at y = 0.5. Edge vertices are
 * duplicated with different normals (the edges are sharp) but carry identical positions,
 * and each side's top edge uses exactly the top grid's boundary vertices, so the box is
 * watertight and has no T-junctions, which matters for rays refracting into it. */
static void add_slab(mesh *m, uint32_t n, const slab_params *q) {
  mesh_add_grid(m, n, n, slab_top_surface, q);
  const double bottom = 0.5;
  uint32_t *t = xrealloc(NULL, sizeof(uint32_t) * (n + 1));
  /* Each side: its outward normal and the grid cells (i, j) along its top edge. */
  for (int side = 0; side < 4; side++) {
    vec3 normal = v3(0, 0, 0);
    for (uint32_t k = 0; k <= n; k++) {
      uint32_t i = 0, j = 0;
      switch (side) {
        case 0:
          i = k, j = 0, normal = v3(0, 0, -1);
          break;
        case 1:
          i = n, j = k, normal = v3(1, 0, 0);
          break;
        case 2:
          i = k, j = n, normal = v3(0, 0, 1);
          break;
        default:
          i = 0, j = k, normal = v3(-1, 0, 0);
          break;
      }
      vec3 p, unused;
      slab_top_surface(q, i, n, j, n, &p, &unused);
      t[k] = mesh_add_vertex(m, p, normal, 0, 0);
    }
    vec3 p0 = mesh_position(m, t[0]), p1 = mesh_position(m, t[n]);
    uint32_t b0 = mesh_add_vertex(m, v3(p0.x, bottom, p0.z), normal, 0, 0);
    uint32_t b1 = mesh_add_vertex(m, v3(p1.x, bottom, p1.z), normal, 0, 0);
    /* Two fans, one from each bottom corner, meeting in the middle: no vertex on the
     * bottom edge is needed, so the bottom can stay two triangles. */
    uint32_t mid = n / 2;
    for (uint32_t k = 0; k < mid; k++) mesh_add_triangle(m, b0, t[k], t[k + 1]);
    mesh_add_triangle(m, b0, t[mid], b1);
    for (uint32_t k = mid; k < n; k++) mesh_add_triangle(m, b1, t[k], t[k + 1]);
  }
  free(t);
  add_plane(m, -1, 1, -1, 1, bottom, -1.0, 1);
}

/* The 12 vertices and 20 faces of an icosahedron. The face winding is fixed up by
 * mesh_add_triangle, but the list is the usual outward counter-clockwise one. */
#define ICO_PHI 1.61803398874989484820 /* the golden ratio */
static const double ICO_VERTICES[12][3] = {
    {-1, ICO_PHI, 0}, {1, ICO_PHI, 0}, {-1, -ICO_PHI, 0}, {1, -ICO_PHI, 0},
    {0, -1, ICO_PHI}, {0, 1, ICO_PHI}, {0, -1, -ICO_PHI}, {0, 1, -ICO_PHI},
    {ICO_PHI, 0, -1}, {ICO_PHI, 0, 1}, {-ICO_PHI, 0, -1}, {-ICO_PHI, 0, 1},
};
static const int ICO_FACES[20][3] = {
    {0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
    {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
    {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1},
};

static vec3 ico_vertex(int i) {
  return v_normalize(v3(ICO_VERTICES[i][0], ICO_VERTICES[i][1], ICO_VERTICES[i][2]));
}

/* A geodesic sphere: each icosahedron face split into n^2 triangles, every vertex pushed
 * onto the sphere, normals radial. Shared corners and edges are created once, so the
 * mesh is closed and indexed (10 n^2 + 2 vertices, 20 n^2 triangles). Vertex positions
 * on an edge are computed once from its lower-numbered corner, so both faces meeting
 * there use the very same vertex. */
static void add_sphere(mesh *m, uint32_t n, vec3 centre, double radius) {
  int edges[30][2], edge_count = 0;
  for (int f = 0; f < 20; f++) {
    for (int e = 0; e < 3; e++) {
      int a = ICO_FACES[f][e], b = ICO_FACES[f][(e + 1) % 3];
      int lo = a < b ? a : b, hi = a < b ? b : a, found = 0;
      for (int k = 0; k < edge_count; k++) found |= edges[k][0] == lo && edges[k][1] == hi;
      if (!found) edges[edge_count][0] = lo, edges[edge_count][1] = hi, edge_count++;
    }
  }
  uint32_t base = m->vertex_count;
#define SPHERE_VERTEX(dir) mesh_add_vertex(m, v_add(centre, v_scale(dir, radius)), dir, 0, 0)
  for (int i = 0; i < 12; i++) SPHERE_VERTEX(ico_vertex(i));
  for (int e = 0; e < 30; e++) {
    vec3 a = ico_vertex(edges[e][0]), b = ico_vertex(edges[e][1]);
    for (uint32_t k = 1; k < n; k++) {
      double s = (double)k / n;
      SPHERE_VERTEX(v_normalize(v_add(v_scale(a, 1 - s), v_scale(b, s))));
    }
  }
  /* grid[j * (n + 1) + i] is the vertex at A + i/n (B - A) + j/n (C - A). */
  uint32_t *grid = xrealloc(NULL, sizeof(uint32_t) * (n + 1) * (n + 1));
  for (int f = 0; f < 20; f++) {
    int A = ICO_FACES[f][0], B = ICO_FACES[f][1], C = ICO_FACES[f][2];
    vec3 a = ico_vertex(A), b = ico_vertex(B), c = ico_vertex(C);
    for (uint32_t j = 0; j <= n; j++) {
      for (uint32_t i = 0; i + j <= n; i++) {
        int from = -1, to = -1; /* the edge the point lies on, if any */
        uint32_t k = 0;         /* its position along that edge, counted from `from` */
        uint32_t id;
        if (i == 0 && j == 0) {
          id = base + (uint32_t)A;
        } else if (i == n) {
          id = base + (uint32_t)B;
        } else if (j == n) {
          id = base + (uint32_t)C;
        } else if (j == 0 || i == 0 || i + j == n) {
          if (j == 0)
            from = A, to = B, k = i;
          else if (i == 0)
            from = A, to = C, k = j;
          else
            from = B, to = C, k = j;
          int lo = from < to ? from : to, hi = from < to ? to : from, e = 0;
          while (edges[e][0] != lo || edges[e][1] != hi) e++;
          if (from != lo) k = n - k;
          id = base + 12 + (uint32_t)e * (n - 1) + (k - 1);
        } else {
          vec3 d = v_add(
              a, v_add(v_scale(v_sub(b, a), (double)i / n), v_scale(v_sub(c, a), (double)j / n)));
          id = SPHERE_VERTEX(v_normalize(d));
        }
        grid[j * (n + 1) + i] = id;
      }
    }
    for (uint32_t j = 0; j < n; j++) {
      for (uint32_t i = 0; i + j < n; i++) {
        uint32_t p00 = grid[j * (n + 1) + i], p10 = grid[j * (n + 1) + i + 1];
        uint32_t p01 = grid[(j + 1) * (n + 1) + i];
        mesh_add_triangle(m, p00, p10, p01);
        if (i + j + 1 < n) mesh_add_triangle(m, p10, grid[(j + 1) * (n + 1) + i + 1], p01);
      }
    }
  }
#undef SPHERE_VERTEX
  free(grid);
}

/* ------------------------------------------------------------------------------------ */
/* Scenes. */

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
  KIND_COUNT
} kind;

typedef struct kind_info {
  const char *name;
  unsigned long default_size;
  const char *summary;
} kind_info;

static const kind_info KINDS[KIND_COUNT] = {
    {"floor", 2, "a 4 x 4 floor under a point light, no caster (E = I cos/r^2)"},
    {"flat-mirror", 2000, "a flat mirror wall beside the floor (mirrored-light test)"},
    {"wavy-mirror", 2000, "a bumpy mirror wall casting a caustic pattern"},
    {"glass-sphere", 2000, "a glass ball (ior 1.5, radius 1) resting on the floor"},
    {"glass-slab", 2000, "a closed glass box (ior 1.5) with a wavy top"},
    {"pool", 2000, "a wavy water surface (ior 1.33) over a pool floor"},
    {"two-mirrors", 8, "two flat mirror walls in a right-angled corner (double reflection)"},
    {"mirror-pool", 2000, "the pool with a mirror above the water and one under it (RT, TR)"},
    {"wavy-corner", 200, "two-mirrors with bumpy walls (double reflection, curved)"},
    {"glass-box", 12, "glass-slab with a flat top: flat parallel faces, finite caustic"},
    {"wavy-plane", 7000, "a wavy mirror plane in the set-up of the shared planes (paper's Plane)"},
    {"glass-pool", 2000, "the pool's water beside a deck with a glass ball, under a warm sun"},
};

typedef struct options {
  kind kind;
  const char *output;
  unsigned long size;
  int size_given;
  unsigned long width, height;
  double area_side; /* 0: a point light */
  double sun;       /* > 0: a directional light of this irradiance (W/m^2) instead */
  double spot;      /* > 0: a spot of this outer cone angle (radians) instead */
  unsigned long orbit; /* 0, or the keyframes of the camera's orbit animation */
  unsigned long checker; /* 0, or the receiver's base colour texture: a checker of N x N */
  double roughness, metallic; /* the receiver's factors (default 1 and 0: Lambertian) */
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

static mesh *scene_add_mesh(scene *s, const char *name, material_kind material, role r) {
  mesh *m = &s->meshes[s->mesh_count++];
  *m = mesh_make(name, material, r, r == ROLE_RECEIVER);
  return m;
}

/* A field of view of 40 degrees, as in the shared ball scenes. */
static const double YFOV = 0.69813170079773179;

static void build_scene(scene *s, const options *o) {
  memset(s, 0, sizeof *s);
  s->opts = o;
  s->color[0] = s->color[1] = s->color[2] = 1;
  s->yfov = YFOV;
  s->up = v3(0, 1, 0);
  unsigned long size = o->size;
  switch (o->kind) {
    case KIND_FLOOR: {
      /* The analytic irradiance test: nothing but the floor and the light 2 above it. The
       * camera looks straight down from 6 above, which frames the whole 4 x 4 floor. */
      mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
      add_plane(floor, -2, 2, -2, 2, 0, 1, square_grid_side(size));
      s->light = v3(0, 2, 0), s->intensity = 10;
      s->eye = v3(0, 6, 0), s->target = v3(0, 0, 0), s->up = v3(0, 0, -1);
      break;
    }
    case KIND_FLAT_MIRROR:
    case KIND_WAVY_MIRROR: {
      int wavy = o->kind == KIND_WAVY_MIRROR;
      uint32_t nz, ny;
      wall_grid(size, &nz, &ny);
      mesh *wall = scene_add_mesh(s, wavy ? "wavy_mirror" : "mirror", MAT_MIRROR, ROLE_CASTER);
      wall_params q = {wavy ? 0.05 : 0.0, 1.0};
      mesh_add_grid(wall, nz, ny, wall_surface, &q);
      mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
      if (!wavy) {
        /* The analytic mirror test: the floor receives the light at (1,1,0) plus exactly
         * that of its mirror image at (-1,1,0); every floor point sees both. The camera
         * looks straight down so pixels map simply to floor points. */
        add_plane(floor, 0, 4, -2, 2, 0, 1, 1);
        s->light = v3(1, 1, 0), s->intensity = 10;
        s->eye = v3(2, 6, 0), s->target = v3(2, 0, 0), s->up = v3(0, 0, -1);
      } else {
        /* The reflected light lands on x in about [0, 5]; the camera looks from beyond
         * the floor's far edge back at the wall, taking in the floor and the mirror. */
        add_plane(floor, -0.5, 5, -3, 3, 0, 1, 1);
        s->light = v3(1.2, 1.2, 0), s->intensity = 20;
        s->eye = v3(7.5, 4.5, 0), s->target = v3(1.8, 0.55, 0);
      }
      break;
    }
    case KIND_GLASS_SPHERE: {
      mesh *ball = scene_add_mesh(s, "glass_sphere", MAT_GLASS, ROLE_CASTER);
      add_sphere(ball, sphere_frequency(size), v3(0, 1, 0), 1.0);
      mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
      add_plane(floor, -3, 3, -3, 3, 0, 1, 1);
      /* A fairly low light, so the ball's focus falls near the floor (a ball lens of
       * index 1.5 focuses about 1.5 radii beyond its centre for distant light). The
       * brightest part of the caustic lands around (-0.8, 0, 1.4), on the side away from
       * the light and towards the camera, outside the ball's silhouette. */
      s->light = v3(1.5, 2.8, -2.5), s->intensity = 30;
      s->eye = v3(0, 5.5, 6.5), s->target = v3(-0.4, 0.4, 0.6);
      break;
    }
    case KIND_GLASS_SLAB: {
      mesh *slab = scene_add_mesh(s, "glass_slab", MAT_GLASS, ROLE_CASTER);
      slab_params q = {0.06, 1.0, 0.8};
      add_slab(slab, slab_grid_side(size), &q);
      mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
      add_plane(floor, -3, 3, -3, 3, 0, 1, 1);
      /* The slab floats 0.5 above the floor and its caustic falls mostly under it, within
       * about 1.3 of the centre; a low camera off the corner sees it through the gap as
       * well as through the glass. */
      s->light = v3(0, 3, 0.5), s->intensity = 20;
      s->eye = v3(3, 2.2, 3.5), s->target = v3(0, 0.25, 0);
      break;
    }
    case KIND_GLASS_BOX: {
      /* The glass slab's box with a flat top: every face flat with flat normals, so the
       * light it transmits is smooth and finite everywhere (no focus), a case for the
       * two-bounce irradiance bounds to stay finite. Same light, floor and camera. */
      mesh *box = scene_add_mesh(s, "glass_box", MAT_GLASS, ROLE_CASTER);
      slab_params q = {0.0, 1.0, 0.8};
      add_slab(box, slab_grid_side(size), &q);
      mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
      add_plane(floor, -3, 3, -3, 3, 0, 1, 1);
      s->light = v3(0, 3, 0.5), s->intensity = 20;
      s->eye = v3(3, 2.2, 3.5), s->target = v3(0, 0.25, 0);
      break;
    }
    case KIND_POOL:
    case KIND_MIRROR_POOL: {
      mesh *water = scene_add_mesh(s, "water", MAT_WATER, ROLE_CASTER);
      uint32_t n = square_grid_side(size);
      mesh_add_grid(water, n, n, pool_surface, NULL);
      mesh *floor = scene_add_mesh(s, "pool_floor", MAT_DIFFUSE, ROLE_RECEIVER);
      add_plane(floor, -2.5, 2.5, -2.5, 2.5, -1.5, 1, 1);
      /* The camera looks straight down through the water at the pool floor. */
      s->light = v3(0.5, 3, 1), s->intensity = 30;
      s->eye = v3(0, 6, 0), s->target = v3(0, -1.5, 0), s->up = v3(0, 0, -1);
      if (o->kind == KIND_MIRROR_POOL) {
        /* Mixed chains: mirror A stands above the water at x = -2, leaning back and
         * facing +x, and sends the light down into the water (RT); mirror B lies under
         * the water at x in [-1.5, -1], tilted to face +x and up, and turns the light
         * that entered the water sideways onto the pool floor (TR). 4 x 4 grids each. */
        mesh *mirrors = scene_add_mesh(s, "mirrors", MAT_MIRROR, ROLE_CASTER);
        rect_params a = {v3(-2, 0.4, -1), v3(0, 0, 2), v3(0.3, 1.5, 0),
                         v_normalize(v3(1.5, -0.3, 0)), 0};
        rect_params b = {v3(-1, -1.45, -1), v3(0, 0, 2), v3(-0.5, 0.8, 0),
                         v_normalize(v3(0.8, 0.5, 0)), 0};
        mesh_add_grid(mirrors, 4, 4, rect_surface, &a);
        mesh_add_grid(mirrors, 4, 4, rect_surface, &b);
      }
      break;
    }
    case KIND_TWO_MIRRORS:
    case KIND_WAVY_CORNER: {
      /* The analytic double-reflection test: mirror A in the plane x = 0 facing +x and
       * mirror B in the plane z = 0 facing +z, each 2 wide and 1.5 high, meet in a right
       * angle over the floor [0,4]^2. Light reflected by both (in either order) comes
       * from the light's image through both planes, (-x, y, -z): a floor point p
       * receives I cos/r^2 from it where the segment from the image to p crosses both
       * mirrors (floor points near one wall and far from the other get none). Each
       * mirror is an n x n grid (2 n^2 triangles, --size counts both); both
       * are one mesh. The camera looks straight down at the floor. */
      mesh *mirrors = scene_add_mesh(s, "mirrors", MAT_MIRROR, ROLE_CASTER);
      uint32_t n = square_grid_side(size / 2 ? size / 2 : 1);
      /* wavy-corner: bumps of 0.04 (two cycles each way), vanishing on the edges. */
      double bump = o->kind == KIND_WAVY_CORNER ? 0.04 : 0.0;
      rect_params a = {v3(0, 0, 0), v3(0, 0, 2), v3(0, 1.5, 0), v3(1, 0, 0), bump};
      rect_params b = {v3(0, 0, 0), v3(2, 0, 0), v3(0, 1.5, 0), v3(0, 0, 1), bump};
      mesh_add_grid(mirrors, n, n, rect_surface, &a);
      mesh_add_grid(mirrors, n, n, rect_surface, &b);
      mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
      add_plane(floor, 0, 4, 0, 4, 0, 1, 1);
      s->light = v3(1.0, 1.0, 0.7), s->intensity = 10;
      s->eye = v3(2, 7, 2), s->target = v3(2, 0, 2), s->up = v3(0, 0, -1);
      break;
    }
    case KIND_GLASS_POOL: {
      /* The demo: the pool's wavy water over its floor (y = -1.5; tiled with --checker),
       * a deck around it at y = 0.05 and a glass ball of radius 0.6 resting
       * on the deck. A warm light from the far side and above: as a point light (the
       * default) or, with --sun, a sun from that direction; the water's caustic falls on
       * the pool floor, the ball's (double refraction) on the deck behind it. --size
       * counts the water's triangles; the ball has 320. */
      mesh *water = scene_add_mesh(s, "water", MAT_WATER, ROLE_CASTER);
      uint32_t n = square_grid_side(size);
      mesh_add_grid(water, n, n, pool_surface, NULL);
      mesh *ball = scene_add_mesh(s, "glass_ball", MAT_GLASS, ROLE_CASTER);
      add_sphere(ball, sphere_frequency(320), v3(3.1, 0.65, 0.3), 0.6);
      mesh *floor = scene_add_mesh(s, "pool_floor", MAT_DIFFUSE, ROLE_RECEIVER);
      add_plane(floor, -2.0, 2.0, -2.0, 2.0, -1.5, 1, 1);
      /* The deck surrounds the pool ([-5, 5]^2 less the pool's [-2, 2]^2); the pool's
       * walls receive the water's caustic too. */
      mesh *deck = scene_add_mesh(s, "deck", MAT_DECK, ROLE_RECEIVER);
      add_plane(deck, 2.0, 5.0, -5.0, 5.0, 0.05, 1, 1);
      add_plane(deck, -5.0, -2.0, -5.0, 5.0, 0.05, 1, 1);
      add_plane(deck, -2.0, 2.0, 2.0, 5.0, 0.05, 1, 1);
      add_plane(deck, -2.0, 2.0, -5.0, -2.0, 0.05, 1, 1);
      mesh *walls = scene_add_mesh(s, "pool_walls", MAT_DECK, ROLE_RECEIVER);
      const rect_params wall[4] = {
          {v3(-2, -1.5, -2), v3(0, 0, 4), v3(0, 1.55, 0), v3(1, 0, 0), 0},
          {v3(2, -1.5, -2), v3(0, 0, 4), v3(0, 1.55, 0), v3(-1, 0, 0), 0},
          {v3(-2, -1.5, -2), v3(4, 0, 0), v3(0, 1.55, 0), v3(0, 0, 1), 0},
          {v3(-2, -1.5, 2), v3(4, 0, 0), v3(0, 1.55, 0), v3(0, 0, -1), 0}};
      for (int k = 0; k < 4; k++) mesh_add_grid(walls, 1, 1, rect_surface, &wall[k]);
      s->light = v3(-2.5, 5.5, -3.0), s->intensity = 60;
      s->color[0] = 1.0, s->color[1] = 0.78, s->color[2] = 0.52;
      s->eye = v3(5.6, 4.6, 4.8), s->target = v3(1.3, -0.7, 0.0);
      break;
    }
    case KIND_WAVY_PLANE: {
      /* The shared planes' set-up: light (3, 1, 4) of 50 W/sr in front of the mirror,
       * receiver [-3, 3]^2 at y = 0, the shared scenes' camera position. An n x n grid,
       * 2 n^2 triangles (--size 458000: the paper's largest plane, n = 479). */
      mesh *plane = scene_add_mesh(s, "wavy_plane", MAT_MIRROR, ROLE_CASTER);
      uint32_t n = square_grid_side(size);
      mesh_add_grid(plane, n, n, wavy_plane_surface, NULL);
      mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
      add_plane(floor, -3, 3, -3, 3, 0, 1, 1);
      s->light = v3(3, 1, 4), s->intensity = 50;
      s->eye = v3(2.709, 4.605, 1.895), s->target = v3(0.981, 1.433, 0.177);
      break;
    }
    default:
      break;
  }
  for (int i = 0; i < s->mesh_count; i++) {
    if (s->meshes[i].role == ROLE_CASTER) s->caster_triangles += s->meshes[i].triangle_count;
  }
  if (o->area_side > 0) {
    /* The area light replaces the point light: a square of the given side centred on the
     * light's position, facing down. A one-sided Lambertian emitter of radiance L and
     * area A emits pi L A; the point light emits 4 pi I, so L = 4 I / A. */
    double h = o->area_side / 2;
    vec3 c = s->light;
    mesh *lamp = scene_add_mesh(s, "area_light", MAT_EMITTER, ROLE_NONE);
    uint32_t v[4];
    for (int k = 0; k < 4; k++) {
      double dx = (k == 1 || k == 2) ? h : -h, dz = k >= 2 ? h : -h;
      v[k] = mesh_add_vertex(lamp, v3(c.x + dx, c.y, c.z + dz), v3(0, -1, 0), 0, 0);
    }
    mesh_add_triangle(lamp, v[0], v[1], v[2]);
    mesh_add_triangle(lamp, v[0], v[2], v[3]);
  }
}

static double emissive_strength(const scene *s) {
  double side = s->opts->area_side;
  return 4.0 * s->intensity / (side * side);
}

static void free_scene(scene *s) {
  for (int i = 0; i < s->mesh_count; i++) mesh_free(&s->meshes[i]);
}

/* The camera rotation as a unit quaternion (x, y, z, w): a glTF camera looks down its
 * local -z with +y up, so the rotation's columns are right, up and back. */
static void look_at(vec3 eye, vec3 target, vec3 up, double q[4]) {
  vec3 w = v_normalize(v_sub(eye, target));
  vec3 u = v_normalize(v_cross(up, w));
  vec3 v = v_cross(w, u);
  double m[3][3] = {{u.x, v.x, w.x}, {u.y, v.y, w.y}, {u.z, v.z, w.z}};
  double tr = m[0][0] + m[1][1] + m[2][2];
  if (tr > 0) {
    double r = 2 * sqrt(1 + tr);
    q[3] = r / 4, q[0] = (m[2][1] - m[1][2]) / r, q[1] = (m[0][2] - m[2][0]) / r;
    q[2] = (m[1][0] - m[0][1]) / r;
  } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
    double r = 2 * sqrt(1 + m[0][0] - m[1][1] - m[2][2]);
    q[3] = (m[2][1] - m[1][2]) / r, q[0] = r / 4, q[1] = (m[0][1] + m[1][0]) / r;
    q[2] = (m[0][2] + m[2][0]) / r;
  } else if (m[1][1] > m[2][2]) {
    double r = 2 * sqrt(1 + m[1][1] - m[0][0] - m[2][2]);
    q[3] = (m[0][2] - m[2][0]) / r, q[0] = (m[0][1] + m[1][0]) / r, q[1] = r / 4;
    q[2] = (m[1][2] + m[2][1]) / r;
  } else {
    double r = 2 * sqrt(1 + m[2][2] - m[0][0] - m[1][1]);
    q[3] = (m[1][0] - m[0][1]) / r, q[0] = (m[0][2] + m[2][0]) / r;
    q[1] = (m[1][2] + m[2][1]) / r, q[2] = r / 4;
  }
  /* q and -q are the same rotation; a non-negative w makes the output unique. */
  double sign = q[3] < 0 ? -1 : 1,
         len = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  for (int i = 0; i < 4; i++) q[i] *= sign / len;
  /* Rounding can leave tiny values of either sign where the rotation has exact zeros;
   * flushing them keeps the JSON clean and the same on every machine. */
  for (int i = 0; i < 4; i++)
    if (fabs(q[i]) < 1e-15) q[i] = 0;
}

/* ------------------------------------------------------------------------------------ */
/* The checker texture: an N x N PNG, written uncompressed (zlib "stored" blocks), so the
 * generator needs no compression library. */

/* The checker's two sRGB colours: light sand and a tile blue. */
static const unsigned char CHECKER_LIGHT[3] = {235, 222, 190};
static const unsigned char CHECKER_DARK[3] = {40, 96, 160};

static uint32_t crc32_update(uint32_t crc, const unsigned char *p, size_t n) {
  crc = ~crc;
  for (size_t i = 0; i < n; i++) {
    crc ^= p[i];
    for (int k = 0; k < 8; k++) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

static void put_be32(bytes *b, uint32_t x) {
  unsigned char c[4] = {(unsigned char)(x >> 24), (unsigned char)(x >> 16),
                        (unsigned char)(x >> 8), (unsigned char)x};
  bytes_append(b, c, 4);
}

static void png_chunk(bytes *png, const char *type, const unsigned char *data, size_t n) {
  put_be32(png, (uint32_t)n);
  size_t start = png->len;
  bytes_append(png, type, 4);
  if (n) bytes_append(png, data, n);
  put_be32(png, crc32_update(0, png->data + start, n + 4));
}

/* Texel (i, j) (column, row from the top) is light where i + j is even. */
static void checker_png(unsigned long n, bytes *png) {
  bytes raw = {0}, z = {0};
  for (unsigned long j = 0; j < n; j++) {
    unsigned char filter = 0;
    bytes_append(&raw, &filter, 1);
    for (unsigned long i = 0; i < n; i++)
      bytes_append(&raw, (i + j) % 2 == 0 ? CHECKER_LIGHT : CHECKER_DARK, 3);
  }
  static const unsigned char zlib_header[2] = {0x78, 0x01};
  bytes_append(&z, zlib_header, 2);
  for (size_t off = 0; off < raw.len || off == 0; off += 65535) {
    size_t len = raw.len - off < 65535 ? raw.len - off : 65535;
    unsigned char h[5] = {(unsigned char)(off + len == raw.len), (unsigned char)len,
                          (unsigned char)(len >> 8), (unsigned char)~len,
                          (unsigned char)(~len >> 8)};
    bytes_append(&z, h, 5);
    bytes_append(&z, raw.data + off, len);
    if (off + len == raw.len) break;
  }
  uint32_t a = 1, b2 = 0;
  for (size_t i = 0; i < raw.len; i++) {
    a = (a + raw.data[i]) % 65521u;
    b2 = (b2 + a) % 65521u;
  }
  put_be32(&z, b2 << 16 | a);
  static const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  bytes_append(png, signature, 8);
  unsigned char ihdr[13] = {(unsigned char)(n >> 24), (unsigned char)(n >> 16),
                            (unsigned char)(n >> 8),  (unsigned char)n,
                            (unsigned char)(n >> 24), (unsigned char)(n >> 16),
                            (unsigned char)(n >> 8),  (unsigned char)n,
                            8, 2, 0, 0, 0}; /* 8-bit RGB, no interlace */
  png_chunk(png, "IHDR", ihdr, 13);
  png_chunk(png, "IDAT", z.data, z.len);
  png_chunk(png, "IEND", NULL, 0);
  free(raw.data);
  free(z.data);
}

/* ------------------------------------------------------------------------------------ */
/* glTF output. */

static const char *const MATERIAL_NAMES[MAT_COUNT] = {"diffuse", "mirror", "glass", "water",
                                                      "emitter", "deck"};

static void json_material(bytes *j, const scene *s, material_kind k) {
  bytes_printf(j, "{\"name\":\"%s\",\"pbrMetallicRoughness\":", MATERIAL_NAMES[k]);
  switch (k) {
    case MAT_DIFFUSE:
      /* With --checker the texture gives the colour (factor 1); --roughness and
       * --metallic make the receiver glossy. */
      bytes_printf(j, "{\"baseColorFactor\":%s,\"metallicFactor\":",
                   s->opts->checker ? "[1,1,1,1]" : "[0.8,0.8,0.8,1]");
      bytes_double(j, s->opts->metallic);
      bytes_printf(j, ",\"roughnessFactor\":");
      bytes_double(j, s->opts->roughness);
      if (s->opts->checker) bytes_printf(j, ",\"baseColorTexture\":{\"index\":0}");
      bytes_printf(j, "}}");
      break;
    case MAT_MIRROR:
      bytes_printf(j,
                   "{\"baseColorFactor\":[1,1,1,1],\"metallicFactor\":1,"
                   "\"roughnessFactor\":0}}");
      break;
    case MAT_GLASS:
    case MAT_WATER:
      bytes_printf(j,
                   "{\"baseColorFactor\":[1,1,1,1],\"metallicFactor\":0,"
                   "\"roughnessFactor\":0},\"extensions\":{"
                   "\"KHR_materials_transmission\":{\"transmissionFactor\":1},"
                   "\"KHR_materials_volume\":{\"thicknessFactor\":1},"
                   "\"KHR_materials_ior\":{\"ior\":%s}}}",
                   k == MAT_GLASS ? "1.5" : "1.33");
      break;
    case MAT_DECK:
      /* glass-pool's deck: light warm stone, matte. */
      bytes_printf(j,
                   "{\"baseColorFactor\":[0.75,0.72,0.66,1],\"metallicFactor\":0,"
                   "\"roughnessFactor\":1}}");
      break;
    default:
      /* A black base colour: the lamp only emits, it reflects nothing. */
      bytes_printf(j,
                   "{\"baseColorFactor\":[0,0,0,1],\"metallicFactor\":0,"
                   "\"roughnessFactor\":1},\"emissiveFactor\":[1,1,1],\"extensions\":{"
                   "\"KHR_materials_emissive_strength\":{\"emissiveStrength\":");
      bytes_double(j, emissive_strength(s));
      bytes_printf(j, "}}}");
      break;
  }
}

static const char *const ROLE_NAMES[] = {"caster", "receiver", "none"};

/* Appends one attribute to the binary buffer and writes its bufferView and accessor;
 * returns the accessor's index. */
typedef struct gltf_writer {
  bytes bin, views, accessors;
  uint32_t view_count, accessor_count;
} gltf_writer;

static uint32_t write_accessor(gltf_writer *g, const void *data, size_t elem_size, uint32_t count,
                               int component, const char *type, int target, const float *min,
                               const float *max, int comps) {
  size_t offset = g->bin.len, length = elem_size * count;
  bytes_append(&g->bin, data, length);
  bytes_pad4(&g->bin, 0);
  bytes_printf(&g->views, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu",
               g->view_count ? "," : "", offset, length);
  if (target) bytes_printf(&g->views, ",\"target\":%d", target); /* none for animation data */
  bytes_printf(&g->views, "}");
  bytes_printf(&g->accessors,
               "%s{\"bufferView\":%u,\"componentType\":%d,\"count\":%u,"
               "\"type\":\"%s\"",
               g->accessor_count ? "," : "", g->view_count, component, count, type);
  if (min) {
    bytes_printf(&g->accessors, ",\"min\":[");
    for (int i = 0; i < comps; i++) {
      if (i) bytes_printf(&g->accessors, ",");
      bytes_float(&g->accessors, min[i]);
    }
    bytes_printf(&g->accessors, "],\"max\":[");
    for (int i = 0; i < comps; i++) {
      if (i) bytes_printf(&g->accessors, ",");
      bytes_float(&g->accessors, max[i]);
    }
    bytes_printf(&g->accessors, "]");
  }
  bytes_printf(&g->accessors, "}");
  g->view_count++;
  return g->accessor_count++;
}

enum {
  GLTF_UNSIGNED_SHORT = 5123,
  GLTF_UNSIGNED_INT = 5125,
  GLTF_FLOAT = 5126,
  GLTF_ARRAY_BUFFER = 34962,
  GLTF_ELEMENT_ARRAY_BUFFER = 34963
};

/* Writes a mesh's attributes and indices; returns the JSON of its primitive. glTF
 * forbids the largest value of the index type as an index (it means primitive restart
 * to some APIs), so 16-bit indices serve up to 65535 vertices, i.e. indices 0..65534. */
static void write_mesh(gltf_writer *g, const mesh *m, int material_index, bytes *meshes_json,
                       int first) {
  float min[3] = {INFINITY, INFINITY, INFINITY}, max[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (uint32_t v = 0; v < m->vertex_count; v++) {
    for (int c = 0; c < 3; c++) {
      float x = m->positions[3 * v + c];
      if (x < min[c]) min[c] = x;
      if (x > max[c]) max[c] = x;
    }
  }
  uint32_t pos = write_accessor(g, m->positions, 12, m->vertex_count, GLTF_FLOAT, "VEC3",
                                GLTF_ARRAY_BUFFER, min, max, 3);
  uint32_t nrm = write_accessor(g, m->normals, 12, m->vertex_count, GLTF_FLOAT, "VEC3",
                                GLTF_ARRAY_BUFFER, NULL, NULL, 3);
  uint32_t uv = 0;
  if (m->has_uv) {
    uv = write_accessor(g, m->uvs, 8, m->vertex_count, GLTF_FLOAT, "VEC2", GLTF_ARRAY_BUFFER, NULL,
                        NULL, 2);
  }
  uint32_t index_count = 3 * m->triangle_count, idx;
  if (m->vertex_count > 65535) {
    idx = write_accessor(g, m->indices, 4, index_count, GLTF_UNSIGNED_INT, "SCALAR",
                         GLTF_ELEMENT_ARRAY_BUFFER, NULL, NULL, 1);
  } else {
    uint16_t *small = xrealloc(NULL, sizeof(uint16_t) * index_count);
    for (uint32_t i = 0; i < index_count; i++) small[i] = (uint16_t)m->indices[i];
    idx = write_accessor(g, small, 2, index_count, GLTF_UNSIGNED_SHORT, "SCALAR",
                         GLTF_ELEMENT_ARRAY_BUFFER, NULL, NULL, 1);
    free(small);
  }
  bytes_printf(meshes_json,
               "%s{\"name\":\"%s\",\"primitives\":[{\"attributes\":{"
               "\"POSITION\":%u,\"NORMAL\":%u",
               first ? "" : ",", m->name, pos, nrm);
  if (m->has_uv) bytes_printf(meshes_json, ",\"TEXCOORD_0\":%u", uv);
  bytes_printf(meshes_json, "},\"indices\":%u,\"material\":%d,\"mode\":4}]}", idx, material_index);
}

static void json_vec3(bytes *j, vec3 v) {
  bytes_printf(j, "[");
  bytes_double(j, v.x);
  bytes_printf(j, ",");
  bytes_double(j, v.y);
  bytes_printf(j, ",");
  bytes_double(j, v.z);
  bytes_printf(j, "]");
}

/* Percent-encodes a file name for the buffer's uri (RFC 3986 unreserved characters pass
 * through), which also keeps the JSON string free of anything needing escapes. */
static void json_uri(bytes *j, const char *name) {
  for (const unsigned char *c = (const unsigned char *)name; *c; c++) {
    if (isalnum(*c) || *c == '-' || *c == '.' || *c == '_' || *c == '~')
      bytes_append(j, c, 1);
    else
      bytes_printf(j, "%%%02X", *c);
  }
}

/* Builds the JSON document and the binary buffer. uri is NULL for a GLB, whose buffer
 * lives in the file's own BIN chunk. */
static void build_gltf(const scene *s, const char *uri, bytes *json, bytes *bin) {
  const options *o = s->opts;
  gltf_writer g;
  memset(&g, 0, sizeof g);
  bytes meshes = {0}, materials = {0};

  /* Materials in order of first use, so the list holds only what the scene uses. */
  int material_index[MAT_COUNT];
  int material_count = 0;
  for (int k = 0; k < MAT_COUNT; k++) material_index[k] = -1;
  for (int i = 0; i < s->mesh_count; i++) {
    material_kind k = s->meshes[i].material;
    if (material_index[k] >= 0) continue;
    if (material_count) bytes_printf(&materials, ",");
    json_material(&materials, s, k);
    material_index[k] = material_count++;
  }
  for (int i = 0; i < s->mesh_count; i++) {
    write_mesh(&g, &s->meshes[i], material_index[s->meshes[i].material], &meshes, i == 0);
  }
  int point_light = o->area_side <= 0;
  /* --sun and --spot turn the point light into a directional light or a spot aimed from
   * the light's position at the origin (the node's -Z, as KHR_lights_punctual says). */
  const char *light_type = o->sun > 0 ? "directional" : o->spot > 0 ? "spot" : "point";
  int transmissive = material_index[MAT_GLASS] >= 0 || material_index[MAT_WATER] >= 0;

  bytes_printf(json, "{\"asset\":{\"version\":\"2.0\",\"generator\":\"" TOOL
                     "\",\"extras\":{\"bbc\":{\"light_units\":\"radiometric\"}}}");
  if (point_light || transmissive || material_index[MAT_EMITTER] >= 0) {
    const char *sep = "";
    bytes_printf(json, ",\"extensionsUsed\":[");
    if (point_light) bytes_printf(json, "%s\"KHR_lights_punctual\"", sep), sep = ",";
    if (transmissive) {
      bytes_printf(json,
                   "%s\"KHR_materials_transmission\",\"KHR_materials_volume\","
                   "\"KHR_materials_ior\"",
                   sep);
      sep = ",";
    }
    if (material_index[MAT_EMITTER] >= 0)
      bytes_printf(json, "%s\"KHR_materials_emissive_strength\"", sep);
    bytes_printf(json, "]");
  }
  if (point_light) {
    bytes_printf(json,
                 ",\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"name\":"
                 "\"light\",\"type\":\"%s\",\"color\":",
                 light_type);
    json_vec3(json, v3(s->color[0], s->color[1], s->color[2]));
    bytes_printf(json, ",\"intensity\":");
    bytes_double(json, o->sun > 0 ? o->sun : s->intensity);
    if (o->spot > 0) {
      bytes_printf(json, ",\"spot\":{\"innerConeAngle\":");
      bytes_double(json, o->spot / 2);
      bytes_printf(json, ",\"outerConeAngle\":");
      bytes_double(json, o->spot);
      bytes_printf(json, "}");
    }
    bytes_printf(json, "}]}}");
  }

  /* Nodes: one per mesh, then the point light, then the camera (and, with --orbit, the
   * side camera). */
  int orbit = o->orbit > 0;
  int node_count = s->mesh_count + point_light + 1 + orbit;
  bytes_printf(json, ",\"scene\":0,\"scenes\":[{\"name\":\"%s\",\"nodes\":[", KINDS[o->kind].name);
  for (int i = 0; i < node_count; i++) bytes_printf(json, "%s%d", i ? "," : "", i);
  bytes_printf(json, "],\"extras\":{\"bbc\":{\"kind\":\"%s\",\"triangles\":%u}}}]",
               KINDS[o->kind].name, s->caster_triangles);
  bytes_printf(json, ",\"nodes\":[");
  for (int i = 0; i < s->mesh_count; i++) {
    bytes_printf(json, "%s{\"name\":\"%s\",\"mesh\":%d,\"extras\":{\"bbc\":{\"role\":\"%s\"}}}",
                 i ? "," : "", s->meshes[i].name, i, ROLE_NAMES[s->meshes[i].role]);
  }
  if (point_light) {
    bytes_printf(json, ",{\"name\":\"light\",\"translation\":");
    json_vec3(json, s->light);
    if (o->sun > 0 || o->spot > 0) {
      vec3 d = v_normalize(v_sub(v3(0, 0, 0), s->light));
      double lq[4];
      look_at(s->light, v3(0, 0, 0), fabs(d.y) > 0.99 ? v3(0, 0, 1) : v3(0, 1, 0), lq);
      bytes_printf(json, ",\"rotation\":[");
      for (int i = 0; i < 4; i++) {
        if (i) bytes_printf(json, ",");
        bytes_double(json, lq[i]);
      }
      bytes_printf(json, "]");
    }
    bytes_printf(json, ",\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}");
  }
  double q[4];
  look_at(s->eye, s->target, s->up, q);
  bytes_printf(json, ",{\"name\":\"camera\",\"camera\":0,\"translation\":");
  json_vec3(json, s->eye);
  bytes_printf(json, ",\"rotation\":[");
  for (int i = 0; i < 4; i++) {
    if (i) bytes_printf(json, ",");
    bytes_double(json, q[i]);
  }
  bytes_printf(json, "],\"extras\":{\"bbc\":{\"width\":%lu,\"height\":%lu}}}", o->width,
               o->height);
  /* --orbit: the camera node turns about its target by 20 degrees over o->orbit keys,
   * one per frame at 24 frames per second (LINEAR), about the axis through the target
   * along the image's up direction; a second, static camera looks from the eye turned
   * by 60 degrees. */
  uint32_t orbit_accessors[3] = {0, 0, 0};
  if (orbit) {
    vec3 d = v_sub(s->eye, s->target);
    vec3 axis = v_normalize(v_cross(v_cross(d, s->up), d)); /* up, orthogonal to d */
    vec3 axis_d = v_cross(axis, d);
#define ORBIT_EYE(a) v_add(s->target, v_add(v_scale(d, cos(a)), v_scale(axis_d, sin(a))))
    vec3 side = ORBIT_EYE(PI / 3);
    look_at(side, s->target, axis, q);
    bytes_printf(json, ",{\"name\":\"side\",\"camera\":1,\"translation\":");
    json_vec3(json, side);
    bytes_printf(json, ",\"rotation\":[");
    for (int i = 0; i < 4; i++) {
      if (i) bytes_printf(json, ",");
      bytes_double(json, q[i]);
    }
    bytes_printf(json, "]}");
    uint32_t keys = (uint32_t)o->orbit;
    float *times = xrealloc(NULL, sizeof(float) * keys);
    float *eyes = xrealloc(NULL, sizeof(float) * 3 * keys);
    float *rotations = xrealloc(NULL, sizeof(float) * 4 * keys);
    for (uint32_t k = 0; k < keys; k++) {
      double a = (20.0 * PI / 180.0) * k / (keys - 1);
      vec3 eye = ORBIT_EYE(a);
      double qk[4];
      look_at(eye, s->target, axis, qk);
      times[k] = (float)(k / 24.0);
      eyes[3 * k] = (float)eye.x, eyes[3 * k + 1] = (float)eye.y, eyes[3 * k + 2] = (float)eye.z;
      for (int i = 0; i < 4; i++) rotations[4 * k + i] = (float)qk[i];
    }
    float t0 = times[0], t1 = times[keys - 1];
    orbit_accessors[0] =
        write_accessor(&g, times, 4, keys, GLTF_FLOAT, "SCALAR", 0, &t0, &t1, 1);
    orbit_accessors[1] =
        write_accessor(&g, eyes, 12, keys, GLTF_FLOAT, "VEC3", 0, NULL, NULL, 3);
    orbit_accessors[2] =
        write_accessor(&g, rotations, 16, keys, GLTF_FLOAT, "VEC4", 0, NULL, NULL, 4);
    free(times);
    free(eyes);
    free(rotations);
#undef ORBIT_EYE
  }
  bytes_printf(json, "]");
  bytes_printf(json,
               ",\"cameras\":[{\"name\":\"camera\",\"type\":\"perspective\","
               "\"perspective\":{\"aspectRatio\":");
  bytes_double(json, (double)o->width / (double)o->height);
  bytes_printf(json, ",\"yfov\":");
  bytes_double(json, s->yfov);
  bytes_printf(json, ",\"znear\":0.01}}");
  if (orbit) {
    bytes_printf(json, ",{\"name\":\"side\",\"type\":\"perspective\",\"perspective\":{"
                       "\"aspectRatio\":");
    bytes_double(json, (double)o->width / (double)o->height);
    bytes_printf(json, ",\"yfov\":");
    bytes_double(json, s->yfov);
    bytes_printf(json, ",\"znear\":0.01}}");
  }
  bytes_printf(json, "]");
  if (orbit) {
    int camera_node = s->mesh_count + point_light;
    bytes_printf(json,
                 ",\"animations\":[{\"name\":\"orbit\",\"channels\":["
                 "{\"sampler\":0,\"target\":{\"node\":%d,\"path\":\"translation\"}},"
                 "{\"sampler\":1,\"target\":{\"node\":%d,\"path\":\"rotation\"}}],"
                 "\"samplers\":[{\"input\":%u,\"output\":%u,\"interpolation\":\"LINEAR\"},"
                 "{\"input\":%u,\"output\":%u,\"interpolation\":\"LINEAR\"}]}]",
                 camera_node, camera_node, orbit_accessors[0], orbit_accessors[1],
                 orbit_accessors[0], orbit_accessors[2]);
  }

  bytes_printf(json, ",\"meshes\":[");
  bytes_append(json, meshes.data, meshes.len);
  bytes_printf(json, "],\"materials\":[");
  bytes_append(json, materials.data, materials.len);
  if (o->checker && material_index[MAT_DIFFUSE] >= 0) {
    /* The checker PNG lives in the buffer, in a bufferView of its own. */
    bytes png = {0};
    checker_png(o->checker, &png);
    size_t offset = g.bin.len;
    bytes_append(&g.bin, png.data, png.len);
    bytes_pad4(&g.bin, 0);
    bytes_printf(&g.views, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}",
                 g.view_count ? "," : "", offset, png.len);
    bytes_printf(json,
                 "],\"images\":[{\"name\":\"checker\",\"bufferView\":%u,"
                 "\"mimeType\":\"image/png\"}],\"samplers\":[{\"magFilter\":9728,"
                 "\"minFilter\":9728,\"wrapS\":10497,\"wrapT\":10497}],"
                 "\"textures\":[{\"source\":0,\"sampler\":0}",
                 g.view_count++);
    free(png.data);
  }
  bytes_printf(json, "],\"accessors\":[");
  bytes_append(json, g.accessors.data, g.accessors.len);
  bytes_printf(json, "],\"bufferViews\":[");
  bytes_append(json, g.views.data, g.views.len);
  bytes_printf(json, "],\"buffers\":[{");
  if (uri) {
    bytes_printf(json, "\"uri\":\"");
    json_uri(json, uri);
    bytes_printf(json, "\",");
  }
  bytes_printf(json, "\"byteLength\":%zu}]}\n", g.bin.len);

  *bin = g.bin;
  free(g.views.data);
  free(g.accessors.data);
  free(meshes.data);
  free(materials.data);
}

/* Packs JSON and buffer into a GLB: a 12-byte header, a JSON chunk padded with spaces and
 * a BIN chunk padded with zeros, all little-endian. */
static void put_u32(bytes *b, uint32_t x) {
  unsigned char c[4] = {(unsigned char)x, (unsigned char)(x >> 8), (unsigned char)(x >> 16),
                        (unsigned char)(x >> 24)};
  bytes_append(b, c, 4);
}

static void build_glb(bytes *json, const bytes *bin, bytes *glb) {
  bytes_pad4(json, ' ');
  size_t bin_len = (bin->len + 3) & ~(size_t)3;
  put_u32(glb, 0x46546C67u); /* "glTF" */
  put_u32(glb, 2);
  put_u32(glb, (uint32_t)(12 + 8 + json->len + 8 + bin_len));
  put_u32(glb, (uint32_t)json->len);
  put_u32(glb, 0x4E4F534Au); /* "JSON" */
  bytes_append(glb, json->data, json->len);
  put_u32(glb, (uint32_t)bin_len);
  put_u32(glb, 0x004E4942u); /* "BIN\0" */
  bytes_append(glb, bin->data, bin->len);
  bytes_pad4(glb, 0);
}

/* Outputs are written to a temporary beside the final name and renamed into place, so a
 * reader never sees a half-written scene and a failed run leaves earlier files intact.
 * The temporary's name carries the process id so that concurrent runs do not collide. */
typedef struct staged_file {
  const char *path; /* the final name */
  char *tmp;        /* the written temporary, or NULL */
} staged_file;

static void report_write_error(const char *path, int err) {
  fprintf(stderr, TOOL ": cannot write %s: %s\n", path, strerror(err));
}

/* Writes data to the temporary of path; on failure says so and returns -1. */
static int stage_file(staged_file *st, const char *path, const void *data, size_t len) {
  size_t n = strlen(path) + 32;
  st->path = path;
  st->tmp = xrealloc(NULL, n);
  snprintf(st->tmp, n, "%s.tmp%ld", path, (long)getpid());
  FILE *f = fopen(st->tmp, "wbx");
  int err = 0;
  if (!f) {
    err = errno;
  } else {
    if (fwrite(data, 1, len, f) != len) err = errno ? errno : EIO;
    if (fclose(f) != 0 && !err) err = errno ? errno : EIO;
    if (err) remove(st->tmp);
  }
  if (err) {
    free(st->tmp);
    st->tmp = NULL;
    report_write_error(path, err);
    return -1;
  }
  return 0;
}

/* Removes a staged temporary that will not be committed; harmless if none was written. */
static void discard_file(staged_file *st) {
  if (st->tmp) remove(st->tmp);
  free(st->tmp);
  st->tmp = NULL;
}

/* Renames the temporary to its final name. */
static int commit_file(staged_file *st) {
  int rc = rename(st->tmp, st->path) == 0 ? 0 : -1;
  if (rc) report_write_error(st->path, errno);
  discard_file(st);
  return rc;
}

/* The buffer of OUT.gltf goes to OUT.bin (any other name gets .bin appended). */
static char *bin_path_for(const char *path) {
  size_t n = strlen(path);
  char *bin = xrealloc(NULL, n + 5);
  memcpy(bin, path, n + 1);
  if (n >= 5 && strcmp(path + n - 5, ".gltf") == 0) bin[n - 5] = '\0';
  strcat(bin, ".bin");
  return bin;
}

static int write_scene(const scene *s) {
  const options *o = s->opts;
  bytes json = {0}, bin = {0};
  int rc = 0;
  if (o->glb) {
    bytes glb = {0};
    build_gltf(s, NULL, &json, &bin);
    build_glb(&json, &bin, &glb);
    staged_file out = {0};
    rc = stage_file(&out, o->output, glb.data, glb.len);
    if (rc == 0) rc = commit_file(&out);
    free(glb.data);
  } else {
    char *bin_path = bin_path_for(o->output);
    const char *slash = strrchr(bin_path, '/');
    build_gltf(s, slash ? slash + 1 : bin_path, &json, &bin);
    /* Both files are written in full before either replaces anything, so the usual
     * failures (no such folder, no permission, disk full) leave an earlier pair as it
     * was. The buffer is renamed first: the new .gltf never points at an older .bin. */
    staged_file out_bin = {0}, out_gltf = {0};
    rc = stage_file(&out_bin, bin_path, bin.data, bin.len);
    if (rc == 0) rc = stage_file(&out_gltf, o->output, json.data, json.len);
    if (rc == 0) rc = commit_file(&out_bin);
    if (rc == 0) rc = commit_file(&out_gltf);
    discard_file(&out_bin);
    discard_file(&out_gltf);
    free(bin_path);
  }
  free(json.data);
  free(bin.data);
  return rc;
}

/* ------------------------------------------------------------------------------------ */
/* Command line. */

static void print_help(FILE *f) {
  fprintf(f,
          "bbc-scenegen: writes the bbc demo and test scenes as glTF 2.0.\n"
          "\n"
          "Usage:\n"
          "  " TOOL
          " KIND -o OUT.gltf [options]   writes OUT.gltf and OUT.bin\n"
          "  " TOOL
          " KIND -o OUT.glb --glb [options]\n"
          "\n"
          "Kinds (y is up; every scene has a diffuse floor as receiver):\n");
  for (int k = 0; k < KIND_COUNT; k++) fprintf(f, "  %-14s %s\n", KINDS[k].name, KINDS[k].summary);
  fprintf(f,
          "\n"
          "Output:\n"
          "  -o, --output PATH     the scene to write (through a temporary file)\n"
          "  --glb                 write one binary .glb instead of .gltf plus .bin\n"
          "\n"
          "Geometry:\n"
          "  --size N              about N caster triangles (default 2000; for floor, the\n"
          "                        floor's own triangles, default 2)\n"
          "\n"
          "Lighting:\n"
          "  --area-light SIDE     instead of the point light, an emissive square of side\n"
          "                        SIDE facing down, of the same total power\n"
          "  --sun E               instead of the point light, a directional light of\n"
          "                        irradiance E (W/m^2) travelling from the light's\n"
          "                        position toward the origin\n"
          "  --spot OUTER          instead of the point light, a spot of the same intensity\n"
          "                        aimed at the origin, cone angles OUTER/2 and OUTER (rad)\n"
          "\n"
          "Camera:\n"
          "  --width W             image width stored with the camera (default 320)\n"
          "  --height H            image height (default 240); aspect ratio is W/H\n"
          "  --orbit N             animate the camera: N keys, one per frame at 24 fps,\n"
          "                        turning it 20 degrees about the vertical axis through\n"
          "                        its target; adds a static second camera \"side\"\n"
          "\n"
          "Receiver:\n"
          "  --checker N           a base colour texture: an N x N checker of sand and blue\n"
          "                        (sRGB PNG in the buffer, NEAREST, REPEAT), texel (0, 0)\n"
          "                        light, over TEXCOORD_0 in [0, 1]\n"
          "  --roughness R         roughnessFactor in [0, 1] (default 1)\n"
          "  --metallic M          metallicFactor in [0, 1] (default 0)\n"
          "\n"
          "Other:\n"
          "  -h, --help            show this help and exit\n"
          "  --version             print the version and exit\n"
          "\n"
          "Options take their value as --opt VALUE or --opt=VALUE. The same arguments\n"
          "always give the same bytes.\n");
}

static int usage_error(const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  fprintf(stderr, TOOL ": ");
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fprintf(stderr, "\nusage: " TOOL
                  " KIND -o OUT.gltf [--size N] [--width W] [--height H]"
                  " [--area-light SIDE | --sun E | --spot OUTER] [--orbit N] [--checker N]"
                  " [--roughness R] [--metallic M] [--glb]\n"
                  "Try '" TOOL " --help' for the kinds and options.\n");
  return 2;
}

/* Strict unsigned integer: digits only (no sign, space or trailing junk), in range. */
static int parse_count(const char *s, unsigned long lo, unsigned long hi, unsigned long *out) {
  if (!isdigit((unsigned char)s[0])) return -1;
  char *end;
  errno = 0;
  unsigned long x = strtoul(s, &end, 10);
  if (errno || *end || x < lo || x > hi) return -1;
  *out = x;
  return 0;
}

/* Strict positive length: a plain decimal number, finite, no trailing junk. */
static int parse_length(const char *s, double hi, double *out) {
  if (!isdigit((unsigned char)s[0]) && s[0] != '.') return -1;
  char *end;
  errno = 0;
  double x = strtod(s, &end);
  if (errno || *end || !isfinite(x) || !(x > 0) || x > hi) return -1;
  *out = x;
  return 0;
}

/* Parses the command line; returns -1 to go on, or the exit status. */
static int parse_args(int argc, char **argv, options *o) {
  memset(o, 0, sizeof *o);
  o->kind = KIND_COUNT;
  o->width = 320, o->height = 240;
  o->roughness = 1;
  for (int i = 1; i < argc; i++) {
    const char *arg = argv[i];
    if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) {
      print_help(stdout);
      return 0;
    }
    if (strcmp(arg, "--version") == 0) {
      printf(TOOL " %s\n", BBC_VERSION);
      return 0;
    }
    if (arg[0] != '-' || arg[1] == '\0') {
      if (o->kind != KIND_COUNT) return usage_error("unexpected argument '%s'", arg);
      for (int k = 0; k < KIND_COUNT; k++)
        if (strcmp(arg, KINDS[k].name) == 0) o->kind = (kind)k;
      if (o->kind == KIND_COUNT) return usage_error("unknown kind '%s'", arg);
      continue;
    }
    /* Split --opt=value; otherwise the value, if the option takes one, is the next
     * argument. */
    char name[32];
    const char *value = NULL, *eq = strchr(arg, '=');
    size_t name_len = eq && arg[1] == '-' ? (size_t)(eq - arg) : strlen(arg);
    if (name_len >= sizeof name) return usage_error("unknown option '%s'", arg);
    memcpy(name, arg, name_len);
    name[name_len] = '\0';
    if (eq && arg[1] == '-') value = eq + 1;
    if (strcmp(name, "--glb") == 0) {
      if (value) return usage_error("option --glb takes no value");
      o->glb = 1;
      continue;
    }
    int known = strcmp(name, "-o") == 0 || strcmp(name, "--output") == 0 ||
                strcmp(name, "--size") == 0 || strcmp(name, "--width") == 0 ||
                strcmp(name, "--height") == 0 || strcmp(name, "--area-light") == 0 ||
                strcmp(name, "--sun") == 0 || strcmp(name, "--spot") == 0 ||
                strcmp(name, "--orbit") == 0 || strcmp(name, "--checker") == 0 ||
                strcmp(name, "--roughness") == 0 || strcmp(name, "--metallic") == 0;
    if (!known) return usage_error("unknown option '%s'", arg);
    if (!value) {
      if (i + 1 >= argc) return usage_error("option %s needs a value", name);
      value = argv[++i];
    }
    if (strcmp(name, "-o") == 0 || strcmp(name, "--output") == 0) {
      if (!value[0]) return usage_error("the output path is empty");
      o->output = value;
    } else if (strcmp(name, "--size") == 0) {
      if (parse_count(value, 1, MAX_SIZE, &o->size))
        return usage_error("--size wants a whole number from 1 to %lu, not '%s'", MAX_SIZE, value);
      o->size_given = 1;
    } else if (strcmp(name, "--width") == 0 || strcmp(name, "--height") == 0) {
      unsigned long *dst = name[2] == 'w' ? &o->width : &o->height;
      if (parse_count(value, 1, MAX_IMAGE_SIDE, dst))
        return usage_error("%s wants a whole number from 1 to %lu, not '%s'", name, MAX_IMAGE_SIDE,
                           value);
    } else if (strcmp(name, "--sun") == 0) {
      if (parse_length(value, 1e9, &o->sun))
        return usage_error("--sun wants an irradiance above 0, not '%s'", value);
    } else if (strcmp(name, "--spot") == 0) {
      if (parse_length(value, 1.5707963267948966, &o->spot))
        return usage_error("--spot wants an outer cone angle in (0, pi/2], not '%s'", value);
    } else if (strcmp(name, "--checker") == 0) {
      if (parse_count(value, 1, 4096, &o->checker))
        return usage_error("--checker wants a whole number of squares from 1 to 4096, not '%s'",
                           value);
    } else if (strcmp(name, "--roughness") == 0 || strcmp(name, "--metallic") == 0) {
      double *dst = name[2] == 'r' ? &o->roughness : &o->metallic;
      char *end;
      errno = 0;
      double x = strtod(value, &end);
      if (!(isdigit((unsigned char)value[0]) || value[0] == '.') || errno || *end ||
          !(x >= 0 && x <= 1))
        return usage_error("%s wants a number from 0 to 1, not '%s'", name, value);
      *dst = x;
    } else if (strcmp(name, "--orbit") == 0) {
      if (parse_count(value, 2, 10000, &o->orbit))
        return usage_error("--orbit wants a whole number of keys from 2 to 10000, not '%s'", value);
    } else {
      if (parse_length(value, MAX_AREA_SIDE, &o->area_side))
        return usage_error("--area-light wants a side length above 0 and at most %g, not '%s'",
                           MAX_AREA_SIDE, value);
    }
  }
  if (o->kind == KIND_COUNT) return usage_error("no scene kind given");
  if ((o->area_side > 0) + (o->sun > 0) + (o->spot > 0) > 1)
    return usage_error("--area-light, --sun and --spot each replace the point light: give one");
  if (!o->output) return usage_error("no output file given (-o OUT.gltf)");
  /* Loaders pick the parser by extension, so a name that says the other format would
   * make a file nothing can read back. */
  size_t n = strlen(o->output);
  if (o->glb && n >= 5 && strcmp(o->output + n - 5, ".gltf") == 0)
    return usage_error("--glb writes binary glTF, but the output ends in .gltf");
  if (!o->glb && n >= 4 && strcmp(o->output + n - 4, ".glb") == 0)
    return usage_error("the output ends in .glb; add --glb to write binary glTF");
  if (!o->size_given) o->size = KINDS[o->kind].default_size;
  return -1;
}

int main(int argc, char **argv) {
  options o;
  int rc = parse_args(argc, argv, &o);
  if (rc >= 0) return rc;
  scene s;
  build_scene(&s, &o);
  rc = write_scene(&s) == 0 ? 0 : 1;
  free_scene(&s);
  return rc;
}
