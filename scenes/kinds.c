/* bbc-scenegen: the scene kinds - meshes, the surfaces they are built from, and one
 * generator per kind in the KINDS table. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scenegen.h"

/* ------------------------------------------------------------------------------------ */
/* Meshes: one glTF mesh with one indexed triangle primitive each. */

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
static double sin_cycles(double k, uint32_t i, uint32_t n);

typedef struct plane_params {
  double x0, x1, z0, z1, y, facing;
  double bend; /* 0, or the height of one wave along x (a bent floor, --floor-bend) */
} plane_params;

static void plane_surface(const void *params, uint32_t i, uint32_t ni, uint32_t j, uint32_t nj,
                          vec3 *p, vec3 *n) {
  const plane_params *q = params;
  double s = (double)i / ni, t = (double)j / nj;
  *p = v3(q->x0 + (q->x1 - q->x0) * s, q->y, q->z0 + (q->z1 - q->z0) * t);
  *n = v3(0, q->facing, 0);
  if (q->bend == 0) return;
  /* One wave of height `bend` across x: y + bend sin(2 pi s), and its normal. */
  const double slope = q->bend * 2 * PI / (q->x1 - q->x0) * cos(2 * PI * s);
  p->y += q->bend * sin_cycles(1, i, ni);
  const double len = sqrt(slope * slope + 1);
  *n = v3(-q->facing * slope / len, q->facing / len, 0);
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

/* glass-pool's water: the pool's waves at 0.7 of their wavelengths. Their crests curve
 * twice as much (a crest of amplitude A and wavenumber k focuses light from above at
 * depth n / ((n - 1) A k^2)): 1.3-1.6 below the surface instead of 2.7-3.3, so the pool
 * floor, 1.5 deep, shows the sharp network of bright lines that sunlit pools have rather
 * than soft bands. */
static const wave GLASS_POOL_WAVES[] = {
    {0.08, 1.12, 0.35, 0.0},
    {0.06, 0.91, 2.2, 1.3},
    {0.045, 0.77, 4.1, 2.7},
};

/* The height h0 + a sum of plane waves at (a, b), and its derivatives. */
static double wave_height(double h0, const wave *waves, size_t count, double a, double b,
                          double *h_a, double *h_b) {
  double h = h0;
  *h_a = 0, *h_b = 0;
  for (size_t w = 0; w < count; w++) {
    const wave *q = &waves[w];
    double k = 2 * PI / q->wavelength;
    double da = cos(q->direction), db = sin(q->direction);
    double arg = k * (a * da + b * db) + q->phase;
    h += q->amplitude * sin(arg);
    *h_a += q->amplitude * k * da * cos(arg);
    *h_b += q->amplitude * k * db * cos(arg);
  }
  return h;
}

#define COUNT_OF(a) (sizeof(a) / sizeof((a)[0]))

/* The water over [-2, 2]^2: POOL_WAVES, or GLASS_POOL_WAVES when params is non-NULL. */
static void pool_surface(const void *params, uint32_t i, uint32_t ni, uint32_t j, uint32_t nj,
                         vec3 *p, vec3 *n) {
  double x = -2.0 + 4.0 * i / ni, z = -2.0 + 4.0 * j / nj, dy_dx, dy_dz;
  double y =
      params ? wave_height(0, GLASS_POOL_WAVES, COUNT_OF(GLASS_POOL_WAVES), x, z, &dy_dx, &dy_dz)
             : wave_height(0, POOL_WAVES, COUNT_OF(POOL_WAVES), x, z, &dy_dx, &dy_dz);
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

static void wavy_plane_surface(const void *params, uint32_t i, uint32_t ni, uint32_t j, uint32_t nj,
                               vec3 *p, vec3 *n) {
  (void)params;
  double x = 0.9 + (double)i / ni, y = 0.0005 + (double)j / nj, dz_dx, dz_dy;
  double z = wave_height(-0.5, PLANE_WAVES, COUNT_OF(PLANE_WAVES), x, y, &dz_dx, &dz_dy);
  *p = v3(x, y, z);
  *n = v3(-dz_dx, -dz_dy, 1.0);
}

/* A heightfield of plane waves over the rectangle [a0, a1] x [b0, b1]: the point
 * (a, h0 + h(a, b), b) when the height runs along y (the pools' water), or (a, b,
 * h0 + h(a, b)) when it runs along z (the standing sheets of the slab); facing is +1
 * or -1, the sign of the normal's component along the height axis. */
typedef struct heightfield {
  double a0, a1, b0, b1, h0, facing;
  int along_z;
  const wave *waves;
  size_t count;
} heightfield;

static void heightfield_surface(const void *params, uint32_t i, uint32_t ni, uint32_t j,
                                uint32_t nj, vec3 *p, vec3 *n) {
  const heightfield *q = params;
  double a = q->a0 + (q->a1 - q->a0) * i / ni, b = q->b0 + (q->b1 - q->b0) * j / nj, h_a, h_b;
  double h = wave_height(q->h0, q->waves, q->count, a, b, &h_a, &h_b);
  vec3 up = v3(-h_a * q->facing, q->facing, -h_b * q->facing);
  *p = q->along_z ? v3(a, b, h) : v3(a, h, b);
  *n = q->along_z ? v3(up.x, up.z, up.y) : up;
}

/* The shared pools' water (the paper's Pool): a wide rectangle around y = 0.297, 2.3
 * above their floor. Its crests (sum of A k^2 about 1.5) focus light from above about
 * 2.7 below, so the floor shows a soft net with bright knots where crests cross. */
static const wave WIDE_POOL_WAVES[] = {
    {0.04, 2.0, 0.3, 0.0},
    {0.032, 1.6, 2.0, 1.2},
    {0.024, 1.25, 4.0, 2.5},
};

/* The shared slab's two sheets (the paper's Slab), standing across z: the front one,
 * facing the light at z = -2, waves by up to 0.07 about z = -0.15; the back one, 0.15
 * behind it, by up to 0.03 about z = 0. */
static const wave SLAB_FRONT_WAVES[] = {
    {0.03, 0.7, 0.5, 0.0},
    {0.022, 0.55, 2.1, 1.0},
    {0.015, 0.45, 3.9, 2.0},
};
static const wave SLAB_BACK_WAVES[] = {
    {0.015, 0.9, 1.2, 0.5},
    {0.012, 0.65, 2.8, 1.7},
};

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
  plane_params q = {x0, x1, z0, z1, y, facing, 0};
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
 * onto the sphere, normals radial (outward for facing +1, inward for -1: the inner
 * surface of a hollow glass, whose normals point out of the glass into the cavity). Shared corners
 * and edges are created once, so the mesh is closed and indexed (10 n^2 + 2 vertices, 20 n^2
 * triangles). Vertex positions on an edge are computed once from its lower-numbered corner, so both
 * faces meeting there use the very same vertex. */
static void add_sphere(mesh *m, uint32_t n, vec3 centre, double radius, double facing) {
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
#define SPHERE_VERTEX(dir) \
  mesh_add_vertex(m, v_add(centre, v_scale(dir, radius)), v_scale(dir, facing), 0, 0)
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

/* A flat facet of a convex solid around `inside`: its own three vertices carry the
 * facet's normal, turned away from `inside`. */
static void add_facet(mesh *m, vec3 a, vec3 b, vec3 c, vec3 inside) {
  vec3 n = v_cross(v_sub(b, a), v_sub(c, a));
  vec3 centroid = v_scale(v_add(v_add(a, b), c), 1.0 / 3.0);
  if (v_dot(n, v_sub(centroid, inside)) < 0) n = v_scale(n, -1);
  mesh_add_triangle(m, mesh_add_vertex(m, a, n, 0, 0), mesh_add_vertex(m, b, n, 0, 0),
                    mesh_add_vertex(m, c, n, 0, 0));
}

/* A round brilliant-like gem with k main facets a side (k = 8 in a real brilliant),
 * standing on its culet at the origin with its table up, girdle radius 0.68: 14 k flat
 * facets, each its own triangle -
 *   crown:    the table (a fan of k), k star facets, k kites (2 each) and 2k upper
 *             girdle facets, between the table at y = 1.2 and the girdle's top at 0.8;
 *   girdle:   a band of 2k quads from y = 0.8 down to 0.74;
 *   pavilion: 2k lower girdle facets and k mains (2 each) down to the culet.
 * Vertices lie on the crown's and the pavilion's cones, so the solid is convex and, by
 * positions, closed. */
static void add_gem(mesh *m, uint32_t k) {
  const double R = 0.68, table_r = 0.55 * R, star_r = 0.78 * R, lower_r = 0.55 * R;
  const double table_y = 1.2, girdle_top = 0.8, girdle_bottom = 0.74, culet_y = 0.023;
  const vec3 inside = v3(0, 0.6, 0), culet = v3(0, culet_y, 0), table_c = v3(0, table_y, 0);
  /* On the crown's cone through (R, girdle_top) and (table_r, table_y), and on the
   * pavilion's through the culet and (R, girdle_bottom). */
  const double star_y = girdle_top + (R - star_r) / (R - table_r) * (table_y - girdle_top);
  const double lower_y = culet_y + lower_r / R * (girdle_bottom - culet_y);
#define GEM_POINT(r, angle, y) v3((r)*cos(angle), (y), (r)*sin(angle))
  for (uint32_t i = 0; i < k; i++) {
    double a0 = 2 * PI * i / k, a1 = 2 * PI * (i + 1) / k, half = a0 + PI / k;
    double prev_half = a0 - PI / k;
    vec3 t0 = GEM_POINT(table_r, a0, table_y), t1 = GEM_POINT(table_r, a1, table_y);
    vec3 star = GEM_POINT(star_r, half, star_y), prev_star = GEM_POINT(star_r, prev_half, star_y);
    vec3 g0 = GEM_POINT(R, a0, girdle_top), gh = GEM_POINT(R, half, girdle_top);
    vec3 g1 = GEM_POINT(R, a1, girdle_top);
    vec3 b0 = GEM_POINT(R, a0, girdle_bottom), bh = GEM_POINT(R, half, girdle_bottom);
    vec3 b1 = GEM_POINT(R, a1, girdle_bottom);
    vec3 lower = GEM_POINT(lower_r, half, lower_y);
    vec3 prev_lower = GEM_POINT(lower_r, prev_half, lower_y);
    add_facet(m, table_c, t0, t1, inside);   /* table */
    add_facet(m, t0, t1, star, inside);      /* star */
    add_facet(m, t0, prev_star, g0, inside); /* kite, two halves */
    add_facet(m, t0, g0, star, inside);
    add_facet(m, star, g0, gh, inside); /* upper girdle */
    add_facet(m, star, gh, g1, inside);
    add_facet(m, g0, gh, bh, inside); /* girdle band */
    add_facet(m, g0, bh, b0, inside);
    add_facet(m, gh, g1, b1, inside);
    add_facet(m, gh, b1, bh, inside);
    add_facet(m, b0, bh, lower, inside); /* lower girdle */
    add_facet(m, bh, b1, lower, inside);
    add_facet(m, b0, lower, culet, inside); /* pavilion main, two halves */
    add_facet(m, b0, culet, prev_lower, inside);
  }
#undef GEM_POINT
}

/* ------------------------------------------------------------------------------------ */
/* Scenes. */

/* The grid side of a receiver floor: one quad, or with --floor-size N a flat grid of
 * about N triangles over the same rectangle (the same plane, the same uvs). */
static uint32_t floor_side(const scene *s) {
  return s->opts->floor_size ? square_grid_side(s->opts->floor_size) : 1;
}

/* A receiver floor: add_plane on floor_side(s)'s grid, bent by --floor-bend. */
static void add_floor(const scene *s, mesh *m, double x0, double x1, double z0, double z1, double y,
                      double facing) {
  plane_params q = {x0, x1, z0, z1, y, facing, s->opts->floor_bend};
  const uint32_t n = floor_side(s);
  mesh_add_grid(m, n, n, plane_surface, &q);
}

static mesh *scene_add_mesh(scene *s, const char *name, material_kind material, role r) {
  mesh *m = &s->meshes[s->mesh_count++];
  *m = mesh_make(name, material, r, r == ROLE_RECEIVER);
  return m;
}

/* A field of view of 40 degrees, as in the shared ball scenes. */
static const double YFOV = 0.69813170079773179;

static void gen_floor(scene *s, unsigned long size) {
  /* The analytic irradiance test: nothing but the floor and the light 2 above it. The
   * camera looks straight down from 6 above, which frames the whole 4 x 4 floor. */
  mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
  add_plane(floor, -2, 2, -2, 2, 0, 1, square_grid_side(size));
  s->light = v3(0, 2, 0), s->intensity = 10;
  s->eye = v3(0, 6, 0), s->target = v3(0, 0, 0), s->up = v3(0, 0, -1);
}

static void gen_mirror_wall(scene *s, unsigned long size) {
  int wavy = s->opts->kind == KIND_WAVY_MIRROR;
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
    add_floor(s, floor, 0, 4, -2, 2, 0, 1);
    s->light = v3(1, 1, 0), s->intensity = 10;
    s->eye = v3(2, 6, 0), s->target = v3(2, 0, 0), s->up = v3(0, 0, -1);
  } else {
    /* The reflected light lands on x in about [0, 5]; the camera looks from beyond
     * the floor's far edge back at the wall, taking in the floor and the mirror. */
    add_floor(s, floor, -0.5, 5, -3, 3, 0, 1);
    s->light = v3(1.2, 1.2, 0), s->intensity = 20;
    s->eye = v3(7.5, 4.5, 0), s->target = v3(1.8, 0.55, 0);
  }
}

static void gen_glass_sphere(scene *s, unsigned long size) {
  mesh *ball = scene_add_mesh(s, "glass_sphere", MAT_GLASS, ROLE_CASTER);
  add_sphere(ball, sphere_frequency(size), v3(0, 1, 0), 1.0, 1.0);
  mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
  add_floor(s, floor, -3, 3, -3, 3, 0, 1);
  /* A fairly low light, so the ball's focus falls near the floor (a ball lens of
   * index 1.5 focuses about 1.5 radii beyond its centre for distant light). The
   * brightest part of the caustic lands around (-0.8, 0, 1.4), on the side away from
   * the light and towards the camera, outside the ball's silhouette. */
  s->light = v3(1.5, 2.8, -2.5), s->intensity = 30;
  s->eye = v3(0, 5.5, 6.5), s->target = v3(-0.4, 0.4, 0.6);
}

static void gen_glass_slab(scene *s, unsigned long size) {
  /* glass-box is the slab with a flat top: every face flat with flat normals, so the
   * light it transmits is smooth and finite everywhere (no focus), a case for the
   * two-bounce irradiance bounds to stay finite. Same light, floor and camera. */
  int box = s->opts->kind == KIND_GLASS_BOX;
  mesh *slab = scene_add_mesh(s, box ? "glass_box" : "glass_slab", MAT_GLASS, ROLE_CASTER);
  slab_params q = {box ? 0.0 : 0.06, 1.0, 0.8};
  add_slab(slab, slab_grid_side(size), &q);
  mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
  add_floor(s, floor, -3, 3, -3, 3, 0, 1);
  /* The slab floats 0.5 above the floor and its caustic falls mostly under it, within
   * about 1.3 of the centre; a low camera off the corner sees it through the gap as
   * well as through the glass. */
  s->light = v3(0, 3, 0.5), s->intensity = 20;
  s->eye = v3(3, 2.2, 3.5), s->target = v3(0, 0.25, 0);
}

static void gen_pool(scene *s, unsigned long size) {
  mesh *water = scene_add_mesh(s, "water", MAT_WATER, ROLE_CASTER);
  uint32_t n = square_grid_side(size);
  mesh_add_grid(water, n, n, pool_surface, NULL);
  mesh *floor = scene_add_mesh(s, "pool_floor", MAT_DIFFUSE, ROLE_RECEIVER);
  add_floor(s, floor, -2.5, 2.5, -2.5, 2.5, -1.5, 1);
  /* The camera looks straight down through the water at the pool floor. */
  s->light = v3(0.5, 3, 1), s->intensity = 30;
  s->eye = v3(0, 6, 0), s->target = v3(0, -1.5, 0), s->up = v3(0, 0, -1);
  if (s->opts->kind == KIND_MIRROR_POOL) {
    /* Mixed chains: mirror A stands above the water at x = -2, leaning back and
     * facing +x, and sends the light down into the water (RT); mirror B lies under
     * the water at x in [-1.5, -1], tilted to face +x and up, and turns the light
     * that entered the water sideways onto the pool floor (TR). 4 x 4 grids each. */
    mesh *mirrors = scene_add_mesh(s, "mirrors", MAT_MIRROR, ROLE_CASTER);
    rect_params a = {v3(-2, 0.4, -1), v3(0, 0, 2), v3(0.3, 1.5, 0), v_normalize(v3(1.5, -0.3, 0)),
                     0};
    rect_params b = {v3(-1, -1.45, -1), v3(0, 0, 2), v3(-0.5, 0.8, 0), v_normalize(v3(0.8, 0.5, 0)),
                     0};
    mesh_add_grid(mirrors, 4, 4, rect_surface, &a);
    mesh_add_grid(mirrors, 4, 4, rect_surface, &b);
  }
}

static void gen_corner(scene *s, unsigned long size) {
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
  double bump = s->opts->kind == KIND_WAVY_CORNER ? 0.04 : 0.0;
  rect_params a = {v3(0, 0, 0), v3(0, 0, 2), v3(0, 1.5, 0), v3(1, 0, 0), bump};
  rect_params b = {v3(0, 0, 0), v3(2, 0, 0), v3(0, 1.5, 0), v3(0, 0, 1), bump};
  mesh_add_grid(mirrors, n, n, rect_surface, &a);
  mesh_add_grid(mirrors, n, n, rect_surface, &b);
  mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
  add_floor(s, floor, 0, 4, 0, 4, 0, 1);
  s->light = v3(1.0, 1.0, 0.7), s->intensity = 10;
  s->eye = v3(2, 7, 2), s->target = v3(2, 0, 2), s->up = v3(0, 0, -1);
}

static void gen_glass_pool(scene *s, unsigned long size) {
  /* The demo: the pool's wavy water over its floor (y = -1.5; tiled with --checker),
   * a deck around it at y = 0.05 and a glass ball of radius 0.6 resting
   * on the deck. A warm light from the left and above: as a point light (the
   * default) or, with --sun, a sun from that direction; the water's caustic falls on
   * the pool floor and a wall, the ball's (double refraction) on the deck beside the
   * ball. --size counts the water's triangles; the ball has 320. */
  mesh *water = scene_add_mesh(s, "water", MAT_WATER, ROLE_CASTER);
  uint32_t n = square_grid_side(size);
  mesh_add_grid(water, n, n, pool_surface, GLASS_POOL_WAVES);
  mesh *ball = scene_add_mesh(s, "glass_ball", MAT_GLASS, ROLE_CASTER);
  add_sphere(ball, sphere_frequency(320), v3(3.1, 0.65, 0.3), 0.6, 1.0);
  mesh *floor = scene_add_mesh(s, "pool_floor", MAT_DIFFUSE, ROLE_RECEIVER);
  add_floor(s, floor, -2.0, 2.0, -2.0, 2.0, -1.5, 1);
  /* The deck surrounds the pool ([-5, 5]^2 less the pool's [-2, 2]^2); the pool's
   * walls receive the water's caustic too. */
  mesh *deck = scene_add_mesh(s, "deck", MAT_DECK, ROLE_RECEIVER);
  add_plane(deck, 2.0, 5.0, -5.0, 5.0, 0.05, 1, 1);
  add_plane(deck, -5.0, -2.0, -5.0, 5.0, 0.05, 1, 1);
  add_plane(deck, -2.0, 2.0, 2.0, 5.0, 0.05, 1, 1);
  add_plane(deck, -2.0, 2.0, -5.0, -2.0, 0.05, 1, 1);
  mesh *walls = scene_add_mesh(s, "pool_walls", MAT_DECK, ROLE_RECEIVER);
  const rect_params wall[4] = {{v3(-2, -1.5, -2), v3(0, 0, 4), v3(0, 1.55, 0), v3(1, 0, 0), 0},
                               {v3(2, -1.5, -2), v3(0, 0, 4), v3(0, 1.55, 0), v3(-1, 0, 0), 0},
                               {v3(-2, -1.5, -2), v3(4, 0, 0), v3(0, 1.55, 0), v3(0, 0, 1), 0},
                               {v3(-2, -1.5, 2), v3(4, 0, 0), v3(0, 1.55, 0), v3(0, 0, -1), 0}};
  for (int k = 0; k < 4; k++) mesh_add_grid(walls, 1, 1, rect_surface, &wall[k]);
  /* The light, on the camera's left and high, lights the far right wall through the
   * water (the far left wall faces away from it) and throws the ball's caustic to the
   * right of the ball, onto open deck. It is 11.4 from the ball and 44 degrees above
   * the deck there: a ball lens of index 1.5 and radius r images the light 1.63 r
   * beyond its centre (paraxially; its marginal rays focus nearer), and the deck is
   * r / sin(44 deg) = 1.44 r away along the axis, about where the rays crowd most, so
   * the caustic is a small bright spot. */
  s->light = v3(-4.5, 8.6, 3.5), s->intensity = 80;
  s->color[0] = 1.0, s->color[1] = 0.78, s->color[2] = 0.52;
  s->eye = v3(5.6, 4.6, 4.8), s->target = v3(1.3, -0.7, 0.0);
}

static void gen_wavy_plane(scene *s, unsigned long size) {
  /* The shared planes' set-up: light (3, 1, 4) of 50 W/sr in front of the mirror,
   * receiver [-3, 3]^2 at y = 0, the shared scenes' camera position. An n x n grid,
   * 2 n^2 triangles (--size 458000: the paper's largest plane, n = 479). */
  mesh *plane = scene_add_mesh(s, "wavy_plane", MAT_MIRROR, ROLE_CASTER);
  uint32_t n = square_grid_side(size);
  mesh_add_grid(plane, n, n, wavy_plane_surface, NULL);
  mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
  add_floor(s, floor, -3, 3, -3, 3, 0, 1);
  s->light = v3(3, 1, 4), s->intensity = 50;
  s->eye = v3(2.709, 4.605, 1.895), s->target = v3(0.981, 1.433, 0.177);
}

/* The shared balls, slab and diamond stand on a 6 x 6 floor under a light of 50 W/sr;
 * the camera looks from (0, 6, 6) (the slab's from (2, 5, 5)) with a field of view of
 * 40 degrees. */
static void add_research_floor(scene *s) {
  mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
  add_floor(s, floor, -3, 3, -3, 3, 0, 1);
  s->intensity = 50;
  s->eye = v3(0, 6, 6), s->target = v3(0, 0, 0.8);
}

static void gen_ball(scene *s, unsigned long size) {
  /* The shared balls' set-up (the paper's Ball): radius 1 on the floor, the light at
   * (1, 2, -2), level with the ball's top and behind it; --size 80, 320, 1280 and
   * 5120 are the shared balls' tessellations. */
  mesh *ball = scene_add_mesh(s, "ball", MAT_GLASS, ROLE_CASTER);
  add_sphere(ball, sphere_frequency(size), v3(0, 1, 0), 1.0, 1.0);
  add_research_floor(s);
  s->light = v3(1, 2, -2);
}

static void gen_slab_sheets(scene *s, unsigned long size) {
  /* The shared slab's set-up (the paper's Slab): two wavy glass sheets 2 x 2 standing
   * on the floor across z, open at their edges (the glass between them is the slab);
   * the front sheet has four fifths of the triangles. The light at (1, 2, -2) shines
   * through both onto the floor behind. */
  mesh *slab = scene_add_mesh(s, "slab", MAT_GLASS, ROLE_CASTER);
  heightfield front = {
      -0.98, 0.98, 0.02, 1.98, -0.15, -1, 1, SLAB_FRONT_WAVES, COUNT_OF(SLAB_FRONT_WAVES)};
  heightfield back = {
      -0.98, 0.98, 0.02, 1.98, 0.0, 1, 1, SLAB_BACK_WAVES, COUNT_OF(SLAB_BACK_WAVES)};
  uint32_t nf = square_grid_side(size * 4 / 5 ? size * 4 / 5 : 1);
  uint32_t nb = square_grid_side(size / 5 ? size / 5 : 1);
  mesh_add_grid(slab, nf, nf, heightfield_surface, &front);
  mesh_add_grid(slab, nb, nb, heightfield_surface, &back);
  add_research_floor(s);
  s->light = v3(1, 2, -2);
  s->eye = v3(2, 5, 5), s->target = v3(0, 0, 1);
}

static void gen_diamond(scene *s, unsigned long size) {
  /* The shared diamond's set-up: a gem of ior 2.42 with flat facets (total internal
   * reflection is common inside it), the light at (1, 3, -2); --size 280 gives 20 main
   * facets a side. */
  mesh *gem = scene_add_mesh(s, "diamond", MAT_DIAMOND, ROLE_CASTER);
  add_gem(gem, size / 14 > 3 ? (uint32_t)(size / 14) : 3);
  add_research_floor(s);
  s->light = v3(1, 3, -2);
}

static void gen_wide_pool(scene *s, unsigned long size) {
  /* The shared pools' set-up (the paper's Pool): water 8.2 x 11.5 over a 16 x 16 floor
   * 2.3 below, the light 3.7 above the water, the camera from (0, 9, 12) with a field
   * of view of 50 degrees. Grid cells are about square. */
  mesh *water = scene_add_mesh(s, "water", MAT_WATER, ROLE_CASTER);
  heightfield q = {-3.8, 4.4, -5.2, 6.3, 0.297, 1, 0, WIDE_POOL_WAVES, COUNT_OF(WIDE_POOL_WAVES)};
  uint32_t nx = round_at_least_1(sqrt(size / 2.0 * 8.2 / 11.5));
  uint32_t nz = round_at_least_1(size / (2.0 * nx));
  mesh_add_grid(water, nx, nz, heightfield_surface, &q);
  mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
  add_floor(s, floor, -8, 8, -8, 8, -2, 1);
  s->light = v3(0.5, 4, 1), s->intensity = 50;
  s->eye = v3(0, 9, 12), s->target = v3(0, 0, 24.0 / 11.0);
  s->yfov = 0.87266462599716477;
}

static void gen_hollow_sphere(scene *s, unsigned long size) {
  /* A hollow glass ball as modellers build one: its outer surface (radius 1, normals
   * out) and its inner surface (radius 0.85, normals into the cavity, out of the glass)
   * are two separate closed meshes; --size counts both, half each. Every ray that enters
   * meets the inner surface (by the sine law at concentric spheres), so each light path
   * to the floor through the glass refracts four times. glass-sphere's floor, light and
   * camera. */
  uint32_t n = sphere_frequency(size / 2 ? size / 2 : 1);
  mesh *outer = scene_add_mesh(s, "hollow_sphere_outer", MAT_GLASS, ROLE_CASTER);
  add_sphere(outer, n, v3(0, 1, 0), 1.0, 1.0);
  mesh *inner = scene_add_mesh(s, "hollow_sphere_inner", MAT_GLASS, ROLE_CASTER);
  add_sphere(inner, n, v3(0, 1, 0), 0.85, -1.0);
  mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
  add_plane(floor, -3, 3, -3, 3, 0, 1, floor_side(s));
  s->light = v3(1.5, 2.8, -2.5), s->intensity = 30;
  s->eye = v3(0, 5.5, 6.5), s->target = v3(-0.4, 0.4, 0.6);
}

/* The glass of water's proportions: outer radius, wall and base thickness, height, the
 * water line and how far the water reaches into the glass. */
#define CUP_R 0.5
#define CUP_WALL 0.05
#define CUP_BASE 0.15
#define CUP_HEIGHT 1.2
#define CUP_WATER 0.8
#define CUP_OVERLAP 0.005
#define CUP_LIFT 0.002 /* the glass stands this far above the floor (no coincident faces) */

/* A vertex of a ring of k about the vertical axis through the glass: angle index i,
 * radius r, height y; the normal is radial (sign +1 out, -1 in) or vertical (up +1 or
 * down -1, radial 0). Positions depend on (i, r, y) alone, so rings shared by two
 * surfaces meet exactly and the meshes are closed. */
static uint32_t ring_vertex(mesh *m, uint32_t i, uint32_t k, double r, double y, double radial,
                            double up) {
  double a = 2 * PI * (double)(i % k) / k;
  vec3 d = v3(cos(a), 0, sin(a));
  return mesh_add_vertex(m, v3(r * d.x, y, r * d.z), v_add(v_scale(d, radial), v3(0, up, 0)), 0, 0);
}

/* A vertical cylinder band of radius r from y0 to y1 in `rows` rows of k quads, normals
 * radial (facing +1 out, -1 in). */
static void add_band(mesh *m, uint32_t k, uint32_t rows, double r, double y0, double y1,
                     double facing) {
  for (uint32_t j = 0; j < rows; j++) {
    double ya = y0 + (y1 - y0) * j / rows,
           yb = j + 1 == rows ? y1 : y0 + (y1 - y0) * (j + 1) / rows;
    for (uint32_t i = 0; i < k; i++) {
      uint32_t a = ring_vertex(m, i, k, r, ya, facing, 0),
               b = ring_vertex(m, i + 1, k, r, ya, facing, 0);
      uint32_t c = ring_vertex(m, i + 1, k, r, yb, facing, 0),
               d = ring_vertex(m, i, k, r, yb, facing, 0);
      mesh_add_triangle(m, a, b, c);
      mesh_add_triangle(m, a, c, d);
    }
  }
}

/* A horizontal annulus r0 < r1 at height y (r0 = 0: a disk, a fan of k), facing up (+1)
 * or down (-1). */
static void add_annulus(mesh *m, uint32_t k, double r0, double r1, double y, double up) {
  for (uint32_t i = 0; i < k; i++) {
    uint32_t b = ring_vertex(m, i, k, r1, y, 0, up), c = ring_vertex(m, i + 1, k, r1, y, 0, up);
    if (r0 > 0) {
      uint32_t a = ring_vertex(m, i, k, r0, y, 0, up), d = ring_vertex(m, i + 1, k, r0, y, 0, up);
      mesh_add_triangle(m, a, b, c);
      mesh_add_triangle(m, a, c, d);
    } else {
      mesh_add_triangle(m, mesh_add_vertex(m, v3(0, y, 0), v3(0, up, 0), 0, 0), b, c);
    }
  }
}

/* Rows of about square cells for a height h on a ring of k around radius CUP_R. */
static uint32_t cup_rows(double h, uint32_t k) {
  return round_at_least_1(h / (2 * PI * CUP_R / k));
}

static void gen_glass_of_water(scene *s, unsigned long size) {
  /* A glass of water as Blender users model one: the glass is one closed mesh (outer
   * wall, rim, inner wall, the thick base's top and bottom), its normals out of the
   * glass (the inner wall's into the cavity); the water is another closed mesh whose
   * side and bottom reach CUP_OVERLAP into the glass, so that no air is left between
   * them (docs/materials.md, "Media"): the glass-water interface is the glass's inner
   * wall, ior 1.5 / 1.33. The inner wall has a ring at the water line. k segments
   * around, cells about square; --size counts both meshes' triangles. */
  uint32_t k = round_at_least_1(sqrt(size / 2.2));
  if (k < 8) k = 8;
  const double ri = CUP_R - CUP_WALL, y0 = CUP_LIFT, base = CUP_LIFT + CUP_BASE;
  const double top = CUP_LIFT + CUP_HEIGHT, water = CUP_LIFT + CUP_WATER;
  mesh *glass = scene_add_mesh(s, "glass", MAT_GLASS, ROLE_CASTER);
  add_band(glass, k, cup_rows(CUP_HEIGHT, k), CUP_R, y0, top, 1);
  add_annulus(glass, k, ri, CUP_R, top, 1);
  add_band(glass, k, cup_rows(water - base, k), ri, base, water, -1);
  add_band(glass, k, cup_rows(top - water, k), ri, water, top, -1);
  add_annulus(glass, k, 0, ri, base, 1);
  add_annulus(glass, k, 0, CUP_R, y0, -1);
  mesh *liquid = scene_add_mesh(s, "water", MAT_WATER, ROLE_CASTER);
  const double rw = ri + CUP_OVERLAP, bottom = base - CUP_OVERLAP;
  add_band(liquid, k, cup_rows(water - bottom, k), rw, bottom, water, 1);
  add_annulus(liquid, k, 0, rw, water, 1);
  add_annulus(liquid, k, 0, rw, bottom, -1);
  mesh *floor = scene_add_mesh(s, "floor", MAT_DIFFUSE, ROLE_RECEIVER);
  add_plane(floor, -2, 2, -2, 2, 0, 1, floor_side(s));
  /* The light, up and to one side, throws the glass's caustic onto the floor beside it,
   * toward the camera. */
  s->light = v3(1.2, 2.6, -1.2), s->intensity = 20;
  s->eye = v3(0, 3.2, 3.6), s->target = v3(-0.3, 0.35, 0.3);
}

const kind_info KINDS[KIND_COUNT] = {
    {"floor", 2, "a 4 x 4 floor under a point light, no caster (E = I cos/r^2)", gen_floor},
    {"flat-mirror", 2000, "a flat mirror wall beside the floor (mirrored-light test)",
     gen_mirror_wall},
    {"wavy-mirror", 2000, "a bumpy mirror wall casting a caustic pattern", gen_mirror_wall},
    {"glass-sphere", 2000, "a glass ball (ior 1.5, radius 1) resting on the floor",
     gen_glass_sphere},
    {"glass-slab", 2000, "a closed glass box (ior 1.5) with a wavy top", gen_glass_slab},
    {"pool", 2000, "a wavy water surface (ior 1.33) over a pool floor", gen_pool},
    {"two-mirrors", 8, "two flat mirror walls in a right-angled corner (double reflection)",
     gen_corner},
    {"mirror-pool", 2000, "the pool with a mirror above the water and one under it (RT, TR)",
     gen_pool},
    {"wavy-corner", 200, "two-mirrors with bumpy walls (double reflection, curved)", gen_corner},
    {"glass-box", 12, "glass-slab with a flat top: flat parallel faces, finite caustic",
     gen_glass_slab},
    {"wavy-plane", 7000, "a wavy mirror plane in the set-up of the shared planes (paper's Plane)",
     gen_wavy_plane},
    {"glass-pool", 2000, "the pool's water beside a deck with a glass ball, under a warm light",
     gen_glass_pool},
    {"ball", 320, "a glass ball in the set-up of the shared balls (paper's Ball)", gen_ball},
    {"slab-sheets", 10000, "two wavy glass sheets in the set-up of the shared slab (paper's Slab)",
     gen_slab_sheets},
    {"diamond", 280, "a faceted gem (ior 2.42) in the set-up of the shared diamond", gen_diamond},
    {"wide-pool", 4000, "wide wavy water in the set-up of the shared pools (paper's Pool)",
     gen_wide_pool},
    {"hollow-sphere", 1280, "a hollow glass ball (radii 1, 0.85): two separate meshes",
     gen_hollow_sphere},
    {"glass-of-water", 1000, "a thick-based glass with water (ior 1.33, its own mesh) in it",
     gen_glass_of_water},
};

void build_scene(scene *s, const options *o) {
  memset(s, 0, sizeof *s);
  s->opts = o;
  s->color[0] = s->color[1] = s->color[2] = 1;
  s->yfov = YFOV;
  s->up = v3(0, 1, 0);
  unsigned long size = o->size;
  KINDS[o->kind].build(s, size);
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

double emissive_strength(const scene *s) {
  double side = s->opts->area_side;
  return 4.0 * s->intensity / (side * side);
}

void free_scene(scene *s) {
  for (int i = 0; i < s->mesh_count; i++) mesh_free(&s->meshes[i]);
}
