/* Receiver grids (format-spec/bbc-format.md Sec. 6): parameterisations, grid
 * coordinates of receiver triangles, point location and conservative splats. */
#include "bbc/grid.h"
#include "bbc/tuple.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "grid_internal.h"
#include "report_internal.h"

const char *bbc_parameterisation_name(uint32_t parameterisation) {
  switch (parameterisation) {
    case BBC_PARAM_TEXCOORD:
      return "texcoord";
    case BBC_PARAM_PLANAR:
      return "planar";
    case BBC_PARAM_BOX:
      return "box";
    case BBC_PARAM_PLANE:
      return "plane";
  }
  return "unknown";
}

static void load3(const float *p, double out[3]) {
  out[0] = p[0];
  out[1] = p[1];
  out[2] = p[2];
}

static double dot3(const double a[3], const double b[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double out[3]) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

/* Sec. 6.1: TEXCOORD_0 is usable when present, finite and of positive extent in u and
 * in v; a degenerate uv set would put the whole receiver into one row or column. */
static int uvs_usable(const bbc_scene *scene, const bbc_mesh *mesh) {
  if (!mesh->has_uvs || !scene->uvs || mesh->vertex_count == 0) return 0;
  double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
  for (uint32_t i = 0; i < mesh->vertex_count; i++) {
    const float *uv = &scene->uvs[2 * (size_t)(mesh->first_vertex + i)];
    for (int k = 0; k < 2; k++) {
      if (!isfinite(uv[k])) return 0;
      if (uv[k] < lo[k]) lo[k] = uv[k];
      if (uv[k] > hi[k]) hi[k] = uv[k];
    }
  }
  return hi[0] > lo[0] && hi[1] > lo[1];
}

/* Sec. 6.2: the normal of a planar mesh, or 0 if the mesh is not planar. */
static int planar_normal(const bbc_scene *scene, const bbc_mesh *mesh, double n[3]) {
  double s[3] = {0, 0, 0};
  for (uint32_t t = 0; t < mesh->triangle_count; t++) {
    const uint32_t *idx = &scene->indices[3 * (size_t)(mesh->first_triangle + t)];
    double p0[3], p1[3], p2[3], e1[3], e2[3], c[3];
    load3(&scene->positions[3 * (size_t)idx[0]], p0);
    load3(&scene->positions[3 * (size_t)idx[1]], p1);
    load3(&scene->positions[3 * (size_t)idx[2]], p2);
    for (int k = 0; k < 3; k++) e1[k] = p1[k] - p0[k], e2[k] = p2[k] - p0[k];
    cross3(e1, e2, c);
    for (int k = 0; k < 3; k++) s[k] += c[k];
  }
  double len = sqrt(dot3(s, s));
  if (!(len > 0) || !isfinite(len)) return 0;
  for (int k = 0; k < 3; k++) n[k] = s[k] / len;

  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (uint32_t i = 0; i < mesh->vertex_count; i++) {
    const float *p = &scene->positions[3 * (size_t)(mesh->first_vertex + i)];
    for (int k = 0; k < 3; k++) {
      if (p[k] < lo[k]) lo[k] = p[k];
      if (p[k] > hi[k]) hi[k] = p[k];
    }
  }
  double diag[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
  double tolerance = 1e-5 * sqrt(dot3(diag, diag));
  double q[3];
  load3(&scene->positions[3 * (size_t)mesh->first_vertex], q);
  for (uint32_t i = 0; i < mesh->vertex_count; i++) {
    double p[3], d[3];
    load3(&scene->positions[3 * (size_t)(mesh->first_vertex + i)], p);
    for (int k = 0; k < 3; k++) d[k] = p[k] - q[k];
    if (fabs(dot3(d, n)) > tolerance) return 0;
  }
  return 1;
}

/* The parameter (u, v) of scene vertex i for a receiver. */
static void vertex_param(const bbc_scene *scene, const bbc_receiver *r, uint32_t i, double out[2]) {
  if (r->parameterisation == BBC_PARAM_TEXCOORD) {
    out[0] = scene->uvs[2 * (size_t)i];
    out[1] = scene->uvs[2 * (size_t)i + 1];
  } else {
    double p[3];
    load3(&scene->positions[3 * (size_t)i], p);
    out[0] = dot3(p, r->axis_u);
    out[1] = dot3(p, r->axis_v);
  }
}

/* Chooses the parameterisation of a receiver mesh and its axes (Sec. 6.1-6.3). */
static void choose_parameterisation(const bbc_scene *scene, const bbc_mesh *mesh, bbc_receiver *r) {
  double n[3];
  memset(r->axis_u, 0, sizeof r->axis_u);
  memset(r->axis_v, 0, sizeof r->axis_v);
  if (mesh->plane != 0) {
    /* Sec. 6.5: the plane's two other axes, a < b. */
    const int axis = mesh->plane - 1;
    r->parameterisation = BBC_PARAM_PLANE;
    r->axis_u[axis == 0 ? 1 : 0] = 1;
    r->axis_v[axis == 2 ? 1 : 2] = 1;
  } else if (uvs_usable(scene, mesh)) {
    r->parameterisation = BBC_PARAM_TEXCOORD;
  } else if (planar_normal(scene, mesh, n)) {
    r->parameterisation = BBC_PARAM_PLANAR;
    int k = 0;
    for (int j = 1; j < 3; j++)
      if (fabs(n[j]) < fabs(n[k])) k = j;
    double e[3] = {0, 0, 0};
    e[k] = 1;
    double d = dot3(e, n), t[3];
    for (int j = 0; j < 3; j++) t[j] = e[j] - d * n[j];
    double len = sqrt(dot3(t, t));
    for (int j = 0; j < 3; j++) r->axis_u[j] = t[j] / len;
    cross3(n, r->axis_u, r->axis_v);
  } else {
    r->parameterisation = BBC_PARAM_BOX;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t i = 0; i < mesh->vertex_count; i++) {
      const float *p = &scene->positions[3 * (size_t)(mesh->first_vertex + i)];
      for (int k = 0; k < 3; k++) {
        if (p[k] < lo[k]) lo[k] = p[k];
        if (p[k] > hi[k]) hi[k] = p[k];
      }
    }
    int order[3] = {0, 1, 2};
    double ext[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    /* A stable sort of three axes by decreasing extent, ties by increasing index. */
    for (int a = 0; a < 3; a++)
      for (int b = 0; b + 1 < 3 - a; b++)
        if (ext[order[b + 1]] > ext[order[b]]) {
          int tmp = order[b];
          order[b] = order[b + 1];
          order[b + 1] = tmp;
        }
    r->axis_u[order[0]] = 1;
    r->axis_v[order[1]] = 1;
  }
}

/* Grid size of a projected receiver (Sec. 6.3): the longer side gets `resolution`
 * cells and cells are square on the surface. */
static uint32_t short_side(uint32_t resolution, double longer, double shorter) {
  double c = ceil((double)resolution * (shorter / longer));
  if (!(c >= 1)) return 1;
  if (c > resolution) return resolution;
  return (uint32_t)c;
}

/* Sec. 6.4: grid coordinate of a parameter, rounded to binary32 and clamped. */
static float grid_coord(double p, double lo, double scale, uint32_t cells) {
  float g = (float)((p - lo) * scale);
  if (!(g >= 0.0f)) g = 0.0f;
  if (g > (float)cells) g = (float)cells;
  return g;
}

bbc_result bbc_grid_create(bbc_grid **out, const bbc_scene *scene, uint32_t resolution,
                           bbc_message_fn error_fn, void *user) {
  if (out) *out = NULL;
  if (!out || !scene)
    return bbc__report(error_fn, user, BBC_ERR_INVALID_ARGUMENT, "bbc_grid_create: NULL argument");
  if (resolution < 1 || resolution > 65536)
    return bbc__report(error_fn, user, BBC_ERR_INVALID_ARGUMENT,
                       "grid resolution %u is outside [1, 65536]", resolution);

  uint32_t count = 0;
  uint64_t uv_count = 0;
  uint32_t last_end = 0;
  for (uint32_t m = 0; m < scene->mesh_count; m++) {
    const bbc_mesh *mesh = &scene->meshes[m];
    if (mesh->role != BBC_ROLE_RECEIVER || mesh->triangle_count == 0) continue;
    /* Lookups find a triangle's receiver by bisection over the triangle ranges, which
     * therefore must increase with the mesh index (the loader builds them that way). */
    if (mesh->first_triangle < last_end ||
        (uint64_t)mesh->first_triangle + mesh->triangle_count > scene->triangle_count)
      return bbc__report(error_fn, user, BBC_ERR_INVALID_ARGUMENT,
                         "%s: mesh %u: triangle range not increasing or out of the scene",
                         scene->path, m);
    last_end = mesh->first_triangle + mesh->triangle_count;
    count++;
    if (!mesh->plane) uv_count += mesh->triangle_count; /* Sec. 5.4: a plane has none */
  }

  bbc_grid *g = calloc(1, sizeof *g);
  bbc_receiver *receivers = calloc(count ? count : 1, sizeof *receivers);
  float *uv = malloc(sizeof(float) * 6 * (uv_count ? uv_count : 1));
  if (!g || !receivers || !uv) {
    free(g);
    free(receivers);
    free(uv);
    return bbc__report(error_fn, user, BBC_ERR_OUT_OF_MEMORY, "%s: out of memory for grids",
                       scene->path);
  }

  uint32_t ri = 0;
  uint64_t first_cell = 0, first_uv = 0;
  for (uint32_t m = 0; m < scene->mesh_count; m++) {
    const bbc_mesh *mesh = &scene->meshes[m];
    if (mesh->role != BBC_ROLE_RECEIVER || mesh->triangle_count == 0) continue;
    bbc_receiver *r = &receivers[ri++];
    r->mesh = m;
    r->first_triangle = mesh->first_triangle;
    r->triangle_count = mesh->triangle_count;
    choose_parameterisation(scene, mesh, r);

    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (uint32_t i = 0; i < mesh->vertex_count; i++) {
      double p[2];
      vertex_param(scene, r, mesh->first_vertex + i, p);
      for (int k = 0; k < 2; k++) {
        if (p[k] < lo[k]) lo[k] = p[k];
        if (p[k] > hi[k]) hi[k] = p[k];
      }
    }
    if (!(lo[0] <= hi[0])) lo[0] = hi[0] = 0; /* no vertex: a degenerate domain */
    if (!(lo[1] <= hi[1])) lo[1] = hi[1] = 0;
    double lu = hi[0] - lo[0], lv = hi[1] - lo[1];
    if (r->parameterisation == BBC_PARAM_TEXCOORD) {
      r->width = r->height = resolution;
    } else if (lu == 0 && lv == 0) {
      r->width = r->height = 1;
    } else if (lu >= lv) {
      /* Square cells on the surface: the shorter side of the domain is extended to a
       * whole number of cells of the longer side's size (Sec. 6.3). */
      r->width = resolution;
      r->height = short_side(resolution, lu, lv);
      hi[1] = lo[1] + (double)r->height * (lu / (double)r->width);
    } else {
      r->height = resolution;
      r->width = short_side(resolution, lv, lu);
      hi[0] = lo[0] + (double)r->width * (lv / (double)r->height);
    }
    lu = hi[0] - lo[0];
    lv = hi[1] - lo[1];
    r->domain[0] = lo[0];
    r->domain[1] = lo[1];
    r->domain[2] = hi[0];
    r->domain[3] = hi[1];
    r->first_cell = first_cell;
    r->first_uv = first_uv;
    first_cell += (uint64_t)r->width * r->height;
    bbc__grid_plane_coords(r);

    double su = lu > 0 ? (double)r->width / lu : 0.0;
    double sv = lv > 0 ? (double)r->height / lv : 0.0;
    if (r->parameterisation == BBC_PARAM_PLANE) continue; /* located by the point */
    for (uint32_t t = 0; t < mesh->triangle_count; t++) {
      const uint32_t *idx = &scene->indices[3 * (size_t)(mesh->first_triangle + t)];
      float *dst = &uv[6 * (first_uv + t)];
      for (int k = 0; k < 3; k++) {
        double p[2];
        vertex_param(scene, r, idx[k], p);
        dst[2 * k] = grid_coord(p[0], lo[0], su, r->width);
        dst[2 * k + 1] = grid_coord(p[1], lo[1], sv, r->height);
      }
    }
    first_uv += mesh->triangle_count;
  }

  g->resolution = resolution;
  g->receiver_count = count;
  g->receivers = receivers;
  g->uv_triangle_count = uv_count;
  g->triangle_uv = uv;
  bbc__grid_set_levels(g, receivers, 1);
  *out = g;
  return BBC_OK;
}

void bbc_grid_free(bbc_grid *grid) {
  if (!grid) return;
  free((void *)grid->receivers);
  free((void *)grid->triangle_uv);
  free(grid);
}

void bbc__grid_set_levels(bbc_grid *g, bbc_receiver *receivers, uint32_t levels) {
  uint64_t cells = 0;
  for (uint32_t i = 0; i < g->receiver_count; i++)
    cells += (uint64_t)receivers[i].width * receivers[i].height;
  for (uint32_t i = 0; i < g->receiver_count; i++) {
    receivers[i].first_coarse_cell = cells;
    for (uint32_t k = 1; k < levels; k++)
      cells += (((uint64_t)(receivers[i].width - 1) >> k) + 1) *
               (((uint64_t)(receivers[i].height - 1) >> k) + 1);
  }
  g->levels = levels;
  g->cell_count = cells;
}

uint32_t bbc__grid_beam_levels(uint32_t resolution) {
  uint32_t levels = 1;
  while (((uint64_t)8 << (levels - 1)) < resolution) levels++;
  return levels;
}

void bbc__grid_plane_coords(bbc_receiver *r) {
  memset(r->plane_uv, 0, sizeof r->plane_uv);
  if (r->parameterisation != BBC_PARAM_PLANE) return;
  const double lu = r->domain[2] - r->domain[0], lv = r->domain[3] - r->domain[1];
  const double L = lu > lv ? lu : lv;
  const double su = lu > 0 ? (double)r->width / lu : 0.0;
  const double sv = lv > 0 ? (double)r->height / lv : 0.0;
  r->plane_uv[2] = (float)(2 * L * su);
  r->plane_uv[5] = (float)(2 * L * sv);
}

/* The receiver of the plane of mesh m, or -1. */
static int64_t plane_receiver(const bbc_grid *grid, uint32_t m) {
  uint32_t lo = 0, hi = grid->receiver_count;
  while (lo < hi) {
    uint32_t mid = lo + (hi - lo) / 2;
    if (grid->receivers[mid].mesh < m)
      lo = mid + 1;
    else
      hi = mid;
  }
  if (lo == grid->receiver_count || grid->receivers[lo].mesh != m ||
      grid->receivers[lo].parameterisation != BBC_PARAM_PLANE)
    return -1;
  return (int64_t)lo;
}

int64_t bbc_grid_receiver_of(const bbc_grid *grid, uint32_t triangle) {
  if (bbc_receiver_is_plane(triangle))
    return plane_receiver(grid, bbc_receiver_plane_mesh(triangle));
  uint32_t lo = 0, hi = grid->receiver_count;
  /* The last receiver whose range starts at or before the triangle. */
  while (lo < hi) {
    uint32_t mid = lo + (hi - lo) / 2;
    if (grid->receivers[mid].first_triangle <= triangle)
      lo = mid + 1;
    else
      hi = mid;
  }
  if (lo == 0) return -1;
  const bbc_receiver *r = &grid->receivers[lo - 1];
  if (triangle - r->first_triangle >= r->triangle_count) return -1;
  return (int64_t)(lo - 1);
}

/* The cell of a grid coordinate along an axis of `cells` cells; NaN goes to 0. */
static uint32_t cell_of(double g, uint32_t cells) {
  if (!(g >= 0)) return 0;
  if (g >= (double)cells) return cells - 1;
  return (uint32_t)floor(g);
}

static const float *triangle_coords(const bbc_grid *grid, const bbc_receiver *r,
                                    uint32_t triangle) {
  if (bbc_receiver_is_plane(triangle)) return r->plane_uv;
  return &grid->triangle_uv[6 * (r->first_uv + (triangle - r->first_triangle))];
}

/* Sec. 6.4: the affine map of a triangle, in this exact order of operations, shared by
 * lookups and splats so both round alike. */
static double affine(const float *g, int axis, double b1, double b2) {
  double g0 = g[axis], g1 = g[2 + axis], g2 = g[4 + axis];
  return g0 + b1 * (g1 - g0) + b2 * (g2 - g0);
}

int bbc__grid_tuple_end(const bbc_grid *grid, uint32_t receiver) {
  const int64_t ri = bbc_grid_receiver_of(grid, receiver);
  return ri >= 0 && (bbc_receiver_is_plane(receiver) ||
                     grid->receivers[ri].parameterisation != BBC_PARAM_PLANE);
}

/* Margin of Sec. 6.4: far above the few-ulp rounding of `affine` at any coordinate up
 * to 65536 cells, far below a cell. A plane's splat (Sec. 6.5) is looked up through the
 * coordinates of the mesh's own triangles, another rounding of the same map: 2^-20
 * covers both (each within a few 2^-24 of the coordinates' size). */
static double splat_margin(uint32_t triangle, double gmax) {
  return ldexp(1.0, bbc_receiver_is_plane(triangle) ? -20 : -30) * (1.0 + gmax);
}

int bbc_grid_locate(const bbc_grid *grid, uint32_t triangle, double b1, double b2,
                    const bbc_vec3 *point, bbc_cell *out) {
  int64_t ri = bbc_grid_receiver_of(grid, triangle);
  if (ri < 0) return 0;
  const bbc_receiver *r = &grid->receivers[ri];
  if (r->parameterisation == BBC_PARAM_PLANE && !bbc_receiver_is_plane(triangle)) {
    /* Sec. 6.5: a plane's triangles are located by the point's projection. */
    if (!point) return 0;
    const double lu = r->domain[2] - r->domain[0], lv = r->domain[3] - r->domain[1];
    const double p[3] = {point->x, point->y, point->z};
    out->receiver = (uint32_t)ri;
    out->x = cell_of((dot3(p, r->axis_u) - r->domain[0]) * ((double)r->width / lu), r->width);
    out->y = cell_of((dot3(p, r->axis_v) - r->domain[1]) * ((double)r->height / lv), r->height);
    return 1;
  }
  const float *g = triangle_coords(grid, r, triangle);
  const double gx = affine(g, 0, b1, b2), gy = affine(g, 1, b1, b2);
  if (bbc_receiver_is_plane(triangle)) {
    /* Off the grid, by the rule of the splats: off the mesh. */
    const double margin = splat_margin(triangle, fmax(g[2], g[5]));
    if (gx - margin >= (double)r->width || gy - margin >= (double)r->height) return 0;
  }
  out->receiver = (uint32_t)ri;
  out->x = cell_of(gx, r->width);
  out->y = cell_of(gy, r->height);
  return 1;
}

int bbc_grid_splat_range(const bbc_grid *grid, uint32_t triangle, double b1_lo, double b1_hi,
                         double b2_lo, double b2_hi, bbc_cell_range *out) {
  int64_t ri = bbc_grid_receiver_of(grid, triangle);
  if (ri < 0) return 0;
  const bbc_receiver *r = &grid->receivers[ri];
  /* A plane's triangles end no tuple: its tuples end on the plane (Sec. 6.5). */
  if (r->parameterisation == BBC_PARAM_PLANE && !bbc_receiver_is_plane(triangle)) return 0;
  const float *g = triangle_coords(grid, r, triangle);

  /* Unknown ends are unbounded; true points lie in the triangle, so clipping the box
   * to [0,1]^2 and testing the corner nearest the origin against b1 + b2 <= 1 loses no
   * point (the rounded sum of two doubles exceeds 1 only if the exact sum does). */
  if (!(b1_lo >= 0)) b1_lo = 0;
  if (!(b2_lo >= 0)) b2_lo = 0;
  if (!(b1_hi <= 1)) b1_hi = 1;
  if (!(b2_hi <= 1)) b2_hi = 1;
  if (b1_lo > b1_hi || b2_lo > b2_hi || b1_lo + b2_lo > 1) return 0;

  double gmax = 0;
  for (int k = 0; k < 6; k++)
    if (fabs(g[k]) > gmax) gmax = fabs(g[k]);
  const double margin = splat_margin(triangle, gmax);

  uint32_t lo_cell[2], hi_cell[2];
  const uint32_t cells[2] = {r->width, r->height};
  for (int axis = 0; axis < 2; axis++) {
    double c[4] = {affine(g, axis, b1_lo, b2_lo), affine(g, axis, b1_hi, b2_lo),
                   affine(g, axis, b1_lo, b2_hi), affine(g, axis, b1_hi, b2_hi)};
    double lo = c[0], hi = c[0];
    for (int k = 1; k < 4; k++) {
      if (c[k] < lo) lo = c[k];
      if (c[k] > hi) hi = c[k];
    }
    /* Clip to the triangle's own bounding rectangle: every true point is inside it. */
    double tlo = g[axis], thi = g[axis];
    for (int k = 1; k < 3; k++) {
      if (g[2 * k + axis] < tlo) tlo = g[2 * k + axis];
      if (g[2 * k + axis] > thi) thi = g[2 * k + axis];
    }
    if (tlo > lo) lo = tlo;
    if (thi < hi) hi = thi;
    /* The exact intersection is not empty (the box holds (b1_lo, b2_lo), a point of
     * the triangle), so an inversion is rounding, smaller than the margin. */
    if (lo > hi) {
      double t = lo;
      lo = hi;
      hi = t;
    }
    /* A plane's triangle reaches past the grid: what lands there is off the mesh. */
    if (lo - margin >= (double)cells[axis]) return 0;
    lo_cell[axis] = cell_of(lo - margin, cells[axis]);
    hi_cell[axis] = cell_of(hi + margin, cells[axis]);
  }
  out->receiver = (uint32_t)ri;
  out->x0 = lo_cell[0];
  out->x1 = hi_cell[0];
  out->y0 = lo_cell[1];
  out->y1 = hi_cell[1];
  return 1;
}

/* Room for the clipped polygon: the box's 4 vertices and one more per cut in exact
 * arithmetic, with room to spare for rounding. */
#define POLYGON_MAX 24

/* Sutherland-Hodgman: the part of polygon p (n vertices in barycentrics) where
 * ka b1 + kb b2 <= c, into q; returns its vertex count, or -1 when it would not fit (n
 * may be -1 then too). */
static int clip_polygon(const double (*p)[2], int n, double ka, double kb, double c,
                        double (*q)[2]) {
  int m = 0;
  if (n < 0 || 2 * n > POLYGON_MAX) return -1;
  for (int i = 0; i < n; i++) {
    const double *a = p[i], *b = p[(i + 1) % n];
    double fa = ka * a[0] + kb * a[1] - c, fb = ka * b[0] + kb * b[1] - c;
    if (fa <= 0) q[m][0] = a[0], q[m][1] = a[1], m++;
    if ((fa < 0 && fb > 0) || (fa > 0 && fb < 0)) {
      double t = fa / (fa - fb);
      if (!(t >= 0)) t = 0;
      if (t > 1) t = 1;
      q[m][0] = a[0] + t * (b[0] - a[0]);
      q[m][1] = a[1] + t * (b[1] - a[1]);
      m++;
    }
  }
  return m;
}

/* Edge i of the polygon (to vertex i + 1) within the band [lo, hi] of a row: its first
 * vertex if inside the band, and its strict crossings of the band's two lines, widen
 * [*xmin, *xmax]. */
static inline void edge_extent(const double *px, const double *py, int n, int i, double lo,
                               double hi, double *xmin, double *xmax) {
  int j = i + 1 < n ? i + 1 : 0;
  double ya = py[i], yb = py[j], xa = px[i], xb = px[j];
  if (ya >= lo && ya <= hi) {
    if (xa < *xmin) *xmin = xa;
    if (xa > *xmax) *xmax = xa;
  }
  if ((ya < lo && yb > lo) || (ya > lo && yb < lo)) {
    double x = xa + (lo - ya) / (yb - ya) * (xb - xa);
    if (x < *xmin) *xmin = x;
    if (x > *xmax) *xmax = x;
  }
  if ((ya < hi && yb > hi) || (ya > hi && yb < hi)) {
    double x = xa + (hi - ya) / (yb - ya) * (xb - xa);
    if (x < *xmin) *xmin = x;
    if (x > *xmax) *xmax = x;
  }
}

/* Rows a polygon's edges are swept over at most (else every edge is tried at every row). */
#define SWEEP_ROWS 1024

/* The x extent of each row y0..y1 (xmin > xmax: none) as edge_extent gives it over
 * every edge, found by trying each edge only at the rows from floor(its lowest y) - 2
 * to floor(its highest y) + 2: its first vertex lies in the band of a row y only if
 * y - 1 - margin <= y_a <= y + margin, and it crosses the row's lines only if they lie
 * strictly between its ends, so (the margin being below 1) in no other row. Returns 0,
 * doing nothing, when the rows are too many or a vertex is not finite. */
static int sweep_edges(const double *px, const double *py, int n, uint32_t y0, uint32_t y1,
                       double margin, double *xmin, double *xmax) {
  if (y1 - y0 >= SWEEP_ROWS || !(margin < 0.5)) return 0;
  for (int i = 0; i < n; i++)
    if (!isfinite(px[i]) || !isfinite(py[i])) return 0;
  for (uint32_t k = 0; k <= y1 - y0; k++) xmin[k] = INFINITY, xmax[k] = -INFINITY;
  for (int i = 0; i < n; i++) {
    const double ya = py[i], yb = py[i + 1 < n ? i + 1 : 0];
    double first = floor(ya < yb ? ya : yb) - 2, last = floor(ya < yb ? yb : ya) + 2;
    if (first < (double)y0) first = (double)y0;
    if (last > (double)y1) last = (double)y1;
    if (first > last) continue;
    for (uint32_t y = (uint32_t)first; y <= (uint32_t)last; y++)
      edge_extent(px, py, n, i, (double)y - margin, (double)y + 1 + margin, &xmin[y - y0],
                  &xmax[y - y0]);
  }
  return 1;
}

int bbc_grid_splat_polygon(const bbc_grid *grid, uint32_t triangle, const double region[8],
                           const double cut[2][4], bbc_cell_range *out, uint32_t *x0,
                           uint32_t *x1) {
  if (!bbc_grid_splat_range(grid, triangle, region[0], region[1], region[2], region[3], out))
    return 0;
  const bbc_receiver *r = &grid->receivers[out->receiver];
  const float *g = triangle_coords(grid, r, triangle);
  double b1_lo = region[0], b1_hi = region[1], b2_lo = region[2], b2_hi = region[3];
  if (!(b1_lo >= 0)) b1_lo = 0;
  if (!(b2_lo >= 0)) b2_lo = 0;
  if (!(b1_hi <= 1)) b1_hi = 1;
  if (!(b2_hi <= 1)) b2_hi = 1;
  /* The cuts, moved out by 2^-40 (barycentrics and the cuts' coefficients are of order
   * 1, so this is far above the rounding of the clipping below and far below a cell);
   * the triangle's own b1 + b2 <= 1 and unknown (NaN) cuts included. Each cut adds at
   * most one vertex to the box's four. */
  const double pad = 0x1p-40;
  double s_lo = region[4] >= 0 ? region[4] : 0, s_hi = region[5] <= 1 ? region[5] : 1;
  double d_lo = region[6] >= -1 ? region[6] : -1, d_hi = region[7] <= 1 ? region[7] : 1;
  double poly[POLYGON_MAX][2] = {{b1_lo, b2_lo}, {b1_hi, b2_lo}, {b1_hi, b2_hi}, {b1_lo, b2_hi}};
  double tmp[POLYGON_MAX][2];
  int n = 4;
  n = clip_polygon((const double(*)[2])poly, n, 1, 1, s_hi + pad, tmp);
  n = clip_polygon((const double(*)[2])tmp, n, -1, -1, -(s_lo - pad), poly);
  n = clip_polygon((const double(*)[2])poly, n, 1, -1, d_hi + pad, tmp);
  n = clip_polygon((const double(*)[2])tmp, n, -1, 1, -(d_lo - pad), poly);
  for (int j = 0; cut && j < 2 && n > 0; j++) {
    const double *c = cut[j];
    if (c[0] == 0 && c[1] == 0) continue;
    n = clip_polygon((const double(*)[2])poly, n, c[0], c[1], c[3] + pad, tmp);
    n = clip_polygon((const double(*)[2])tmp, n, -c[0], -c[1], -(c[2] - pad), poly);
  }
  if (n == 0) return 0;
  if (n < 0) {
    /* Not expected: the box's range, every row whole, is conservative too. */
    for (uint32_t y = out->y0; y <= out->y1; y++) x0[y - out->y0] = out->x0, x1[y - out->y0] = out->x1;
    return 1;
  }
  double gmax = 0;
  for (int k = 0; k < 6; k++)
    if (fabs(g[k]) > gmax) gmax = fabs(g[k]);
  const double margin = splat_margin(triangle, gmax);
  double px[POLYGON_MAX], py[POLYGON_MAX], ylo = INFINITY, yhi = -INFINITY;
  for (int i = 0; i < n; i++) {
    px[i] = affine(g, 0, poly[i][0], poly[i][1]);
    py[i] = affine(g, 1, poly[i][0], poly[i][1]);
    /* Comparisons rather than fmin/fmax (library calls here): NaN is skipped alike, and
     * the sign of a zero end does not matter below (ends are moved by the margin). */
    if (py[i] < ylo) ylo = py[i];
    if (py[i] > yhi) yhi = py[i];
  }
  /* Rows: within the box's range (itself conservative) and the polygon's. */
  uint32_t y0 = cell_of(ylo - margin, r->height), y1 = cell_of(yhi + margin, r->height);
  if (y0 < out->y0) y0 = out->y0;
  if (y1 > out->y1) y1 = out->y1;
  if (y0 > y1) return 0;
  uint32_t bx0 = out->x0, bx1 = out->x1, ux0 = UINT32_MAX, ux1 = 0;
  /* Only rows y0..y1 can be listed (the range shrinks to them below). */
  for (uint32_t y = y0; y <= y1; y++) x0[y - out->y0] = 1, x1[y - out->y0] = 0;
  /* Each row's x extent: the least and greatest of the polygon's vertices in the row's
   * band [y - margin, y + 1 + margin] and of its edges' crossings of the band's two
   * lines. Each edge is tried only at the rows its y extent can reach, with two rows to
   * spare either side for the margin, by the same tests as at every row (sweep_edges);
   * the least and greatest of the same values do not depend on the order they come. */
  double xmin_rows[SWEEP_ROWS], xmax_rows[SWEEP_ROWS];
  const int swept = sweep_edges(px, py, n, y0, y1, margin, xmin_rows, xmax_rows);
  for (uint32_t y = y0; y <= y1; y++) {
    double xmin = INFINITY, xmax = -INFINITY;
    if (swept) {
      xmin = xmin_rows[y - y0], xmax = xmax_rows[y - y0];
    } else {
      const double lo = (double)y - margin, hi = (double)y + 1 + margin;
      for (int i = 0; i < n; i++) edge_extent(px, py, n, i, lo, hi, &xmin, &xmax);
    }
    if (!(xmin <= xmax)) continue;
    uint32_t c0 = cell_of(xmin - margin, r->width), c1 = cell_of(xmax + margin, r->width);
    if (c0 < bx0) c0 = bx0;
    if (c1 > bx1) c1 = bx1;
    if (c0 > c1) continue;
    x0[y - out->y0] = c0, x1[y - out->y0] = c1;
    if (c0 < ux0) ux0 = c0;
    if (c1 > ux1) ux1 = c1;
  }
  if (ux0 > ux1) return 0;
  /* Shrink the range to the rows and columns listed. */
  uint32_t first = y0, last = y1;
  while (first <= last && x0[first - out->y0] > x1[first - out->y0]) first++;
  while (last > first && x0[last - out->y0] > x1[last - out->y0]) last--;
  if (first != out->y0) memmove(x0, x0 + (first - out->y0), (last - first + 1) * sizeof *x0),
                        memmove(x1, x1 + (first - out->y0), (last - first + 1) * sizeof *x1);
  out->y0 = first, out->y1 = last, out->x0 = ux0, out->x1 = ux1;
  return 1;
}
