/* The cells a beam piece reaches (beam_cells_internal.h). */
#include "beam_cells_internal.h"

#include "bbc/interval.h"
#include "scene_internal.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Whether two closed boxes share a point (exact: every value is a double). */
static int boxes_meet(const double alo[3], const double ahi[3], const double blo[3],
                      const double bhi[3]) {
  for (int a = 0; a < 3; a++)
    if (!(ahi[a] >= blo[a] && alo[a] <= bhi[a])) return 0;
  return 1;
}

static int box_holds(const double alo[3], const double ahi[3], const double blo[3],
                     const double bhi[3]) {
  for (int a = 0; a < 3; a++)
    if (!(alo[a] <= blo[a] && ahi[a] >= bhi[a])) return 0;
  return 1;
}

/* The box of the triangle at position j of the BVH's order (b->boxes, exact: the
 * triangles' float coordinates). */
static void order_box(const bbc__beam_receivers *b, uint32_t j, double lo[3], double hi[3]) {
  const float *x = b->boxes + 6 * (size_t)j;
  for (int a = 0; a < 3; a++) lo[a] = x[a], hi[a] = x[3 + a];
}

/* Midpoint split on the node's longest axis, as the tuple search's BVH. */
static uint32_t node_build(bbc__beam_receivers *b, const bbc_scene *scene, uint32_t first,
                           uint32_t count) {
  const uint32_t index = b->node_count++;
  bbc__beam_node node;
  memset(&node, 0, sizeof node);
  for (int a = 0; a < 3; a++) node.lo[a] = INFINITY, node.hi[a] = -INFINITY;
  for (uint32_t i = first; i < first + count; i++) {
    double lo[3], hi[3];
    bbc__triangle_box(scene, b->order[i], lo, hi);
    for (int a = 0; a < 3; a++)
      node.lo[a] = fmin(node.lo[a], lo[a]), node.hi[a] = fmax(node.hi[a], hi[a]);
  }
  if (count <= 4) {
    node.first = first;
    node.count = count;
    b->nodes[index] = node;
    return index;
  }
  int axis = 0;
  for (int a = 1; a < 3; a++)
    if (node.hi[a] - node.lo[a] > node.hi[axis] - node.lo[axis]) axis = a;
  const double mid = 0.5 * (node.lo[axis] + node.hi[axis]);
  uint32_t split = first;
  for (uint32_t i = first; i < first + count; i++) {
    double lo[3], hi[3];
    bbc__triangle_box(scene, b->order[i], lo, hi);
    if (0.5 * (lo[axis] + hi[axis]) < mid) {
      const uint32_t t = b->order[i];
      b->order[i] = b->order[split];
      b->order[split++] = t;
    }
  }
  if (split == first || split == first + count) split = first + count / 2;
  node.left = node_build(b, scene, first, split - first);
  node.right = node_build(b, scene, split, first + count - split);
  b->nodes[index] = node;
  return index;
}

/* The whole triangle as a polygonal position bound of its own barycentrics. */
static const double WHOLE[8] = {0, 1, 0, 1, 0, 1, -1, 1};

/* The part of triangle t inside the box lo..hi, as a polygonal region of its
 * barycentrics (bbc_grid_splat_polygon's {b1, b2, b1 + b2, b1 - b2} bounds) holding it;
 * 0 when the part is empty. The triangle, (0, 0), (1, 0), (0, 1) in barycentrics, is
 * clipped by the six half-planes lo_a <= x_a(b) <= hi_a, each affine in b, each grown by
 * a margin far above the rounding of its evaluation (Sutherland-Hodgman), and the bounds
 * of the clipped polygon's vertices are grown by another: the region holds every point
 * of the triangle in the box, and a part empty by rounding alone is kept. */
static int clipped_region(const bbc_scene *scene, uint32_t t, const double lo[3],
                          const double hi[3], double region[8]) {
  double p[3][3];
  for (int j = 0; j < 3; j++) {
    const float *v = scene->positions + 3 * (size_t)scene->indices[3 * (size_t)t + j];
    for (int a = 0; a < 3; a++) p[j][a] = v[a];
  }
  double poly[2][12][2];
  int n = 3, cur = 0;
  const double start[3][2] = {{0, 0}, {1, 0}, {0, 1}};
  memcpy(poly[0], start, sizeof start);
  for (int a = 0; a < 3 && n > 0; a++) {
    const double e1 = p[1][a] - p[0][a], e2 = p[2][a] - p[0][a];
    for (int side = 0; side < 2 && n > 0; side++) {
      /* f(b) = s (x_a(b) - bound) >= -margin, s = +1 against lo, -1 against hi. */
      const double sign = side ? -1.0 : 1.0, bound = side ? hi[a] : lo[a];
      const double margin =
          64 * DBL_EPSILON * (fabs(p[0][a]) + fabs(e1) + fabs(e2) + fabs(bound)) + DBL_MIN;
      double f[12];
      for (int k = 0; k < n; k++)
        f[k] = sign * (p[0][a] + poly[cur][k][0] * e1 + poly[cur][k][1] * e2 - bound) + margin;
      int m = 0;
      for (int k = 0; k < n; k++) {
        const int l = (k + 1) % n;
        if (f[k] >= 0) poly[!cur][m][0] = poly[cur][k][0], poly[!cur][m++][1] = poly[cur][k][1];
        if ((f[k] >= 0) != (f[l] >= 0)) {
          const double w = f[k] / (f[k] - f[l]);
          poly[!cur][m][0] = poly[cur][k][0] + w * (poly[cur][l][0] - poly[cur][k][0]);
          poly[!cur][m][1] = poly[cur][k][1] + w * (poly[cur][l][1] - poly[cur][k][1]);
          m++;
        }
      }
      n = m;
      cur = !cur;
    }
  }
  if (n == 0) return 0;
  for (int k = 0; k < 4; k++) region[2 * k] = INFINITY, region[2 * k + 1] = -INFINITY;
  for (int k = 0; k < n; k++) {
    const double b1 = poly[cur][k][0], b2 = poly[cur][k][1];
    const double v[4] = {b1, b2, b1 + b2, b1 - b2};
    for (int q = 0; q < 4; q++)
      region[2 * q] = fmin(region[2 * q], v[q]), region[2 * q + 1] = fmax(region[2 * q + 1], v[q]);
  }
  /* The vertices' rounding (interpolations of values in [0, 1]) is far below this. */
  for (int q = 0; q < 4; q++) region[2 * q] -= 1e-9, region[2 * q + 1] += 1e-9;
  return 1;
}

bbc_result bbc__beam_receivers_init(bbc__beam_receivers *b, const bbc_scene *scene,
                                    const bbc_grid *grid) {
  memset(b, 0, sizeof *b);
  for (int a = 0; a < 3; a++) b->lo[a] = INFINITY, b->hi[a] = -INFINITY;
  uint32_t triangles = 0;
  for (uint32_t r = 0; r < grid->receiver_count; r++) {
    if (grid->receivers[r].parameterisation == BBC_PARAM_PLANE) continue;
    b->count++;
    triangles += grid->receivers[r].triangle_count;
  }
  if (b->count == 0) return BBC_OK;
  b->items = calloc(b->count, sizeof *b->items);
  b->order = malloc((triangles ? triangles : 1) * sizeof *b->order);
  b->nodes = malloc(2 * (size_t)(triangles ? triangles : 1) * sizeof *b->nodes);
  b->boxes = malloc(6 * (size_t)(triangles ? triangles : 1) * sizeof *b->boxes);
  if (!b->items || !b->order || !b->nodes || !b->boxes) return BBC_ERR_OUT_OF_MEMORY;
  b->bytes = b->count * sizeof *b->items + triangles * sizeof *b->order +
             2 * (size_t)triangles * sizeof *b->nodes + 6 * (size_t)triangles * sizeof *b->boxes;
  uint32_t *x0 = NULL, *x1 = NULL;
  uint32_t k = 0, at = 0;
  bbc_result res = BBC_OK;
  for (uint32_t r = 0; r < grid->receiver_count && res == BBC_OK; r++) {
    const bbc_receiver *rc = &grid->receivers[r];
    if (rc->parameterisation == BBC_PARAM_PLANE) continue;
    bbc__beam_receiver *item = &b->items[k++];
    item->receiver = r;
    if (rc->width > b->max_width) b->max_width = rc->width;
    if (rc->height > b->max_height) b->max_height = rc->height;
    for (uint32_t t = 0; t < rc->triangle_count; t++) b->order[at + t] = rc->first_triangle + t;
    if (rc->triangle_count == 0) {
      item->root = UINT32_MAX;
      item->mx0 = 1, item->mx1 = 0;
      continue;
    }
    item->root = node_build(b, scene, at, rc->triangle_count);
    for (uint32_t j = at; j < at + rc->triangle_count; j++) {
      double lo[3], hi[3];
      bbc__triangle_box(scene, b->order[j], lo, hi);
      for (int a = 0; a < 3; a++)
        b->boxes[6 * (size_t)j + a] = (float)lo[a], b->boxes[6 * (size_t)j + 3 + a] = (float)hi[a];
    }
    at += rc->triangle_count;
    for (int a = 0; a < 3; a++) {
      item->lo[a] = b->nodes[item->root].lo[a], item->hi[a] = b->nodes[item->root].hi[a];
      b->lo[a] = fmin(b->lo[a], item->lo[a]), b->hi[a] = fmax(b->hi[a], item->hi[a]);
    }
    /* The mask: the union of every triangle's footprint. */
    free(x0);
    free(x1);
    x0 = malloc(rc->height * sizeof *x0);
    x1 = malloc(rc->height * sizeof *x1);
    item->mask = calloc((size_t)rc->width * rc->height, 1);
    if (!x0 || !x1 || !item->mask) {
      res = BBC_ERR_OUT_OF_MEMORY;
      break;
    }
    b->bytes += (size_t)rc->width * rc->height;
    item->mx0 = rc->width, item->my0 = rc->height, item->mx1 = 0, item->my1 = 0;
    int any = 0;
    for (uint32_t t = 0; t < rc->triangle_count; t++) {
      bbc_cell_range c;
      if (!bbc_grid_splat_polygon(grid, rc->first_triangle + t, WHOLE, NULL, &c, x0, x1)) continue;
      for (uint32_t y = c.y0; y <= c.y1; y++)
        for (uint32_t x = x0[y - c.y0]; x <= x1[y - c.y0] && x0[y - c.y0] <= x1[y - c.y0]; x++)
          item->mask[(size_t)y * rc->width + x] = 1;
      any = 1;
      if (c.x0 < item->mx0) item->mx0 = c.x0;
      if (c.y0 < item->my0) item->my0 = c.y0;
      if (c.x1 > item->mx1) item->mx1 = c.x1;
      if (c.y1 > item->my1) item->my1 = c.y1;
    }
    if (!any) item->mx0 = 1, item->mx1 = 0, item->my0 = item->my1 = 0;
  }
  free(x0);
  free(x1);
  return res;
}

void bbc__beam_receivers_free(bbc__beam_receivers *b) {
  for (uint32_t k = 0; b->items && k < b->count; k++) free(b->items[k].mask);
  free(b->items);
  free(b->nodes);
  free(b->order);
  free(b->boxes);
  memset(b, 0, sizeof *b);
}

void bbc__beam_scratch_free(bbc__beam_scratch *s) {
  free(s->row_x0);
  free(s->row_x1);
  free(s->stack);
  memset(s, 0, sizeof *s);
}

static bbc_result scratch_reserve(bbc__beam_scratch *s, const bbc__beam_receivers *b) {
  if (s->rows < b->max_height) {
    free(s->row_x0);
    free(s->row_x1);
    s->row_x0 = malloc(b->max_height * sizeof *s->row_x0);
    s->row_x1 = malloc(b->max_height * sizeof *s->row_x1);
    s->rows = s->row_x0 && s->row_x1 ? b->max_height : 0;
    if (!s->rows) return BBC_ERR_OUT_OF_MEMORY;
  }
  if (s->stack_capacity < b->node_count) {
    free(s->stack);
    s->stack = malloc((b->node_count ? b->node_count : 1) * sizeof *s->stack);
    s->stack_capacity = s->stack ? b->node_count : 0;
    if (!s->stack) return BBC_ERR_OUT_OF_MEMORY;
  }
  return BBC_OK;
}

int bbc__beam_piece_rows(const bbc__beam_receivers *b, const bbc_scene *scene, const bbc_grid *grid,
                         const bbc_beam_piece *p, bbc__beam_scratch *s, bbc__beam_row_fn fn,
                         void *user) {
  for (uint32_t k = 0; k < b->count; k++) {
    const bbc__beam_receiver *item = &b->items[k];
    if (item->root == UINT32_MAX || item->mx0 > item->mx1) continue;
    if (!boxes_meet(p->box_lo, p->box_hi, item->lo, item->hi)) continue;
    const size_t w = grid->receivers[item->receiver].width;
    if (box_holds(p->box_lo, p->box_hi, item->lo, item->hi)) {
      for (uint32_t y = item->my0; y <= item->my1; y++)
        if (fn(user, k, y, item->mx0, item->mx1, item->mask + y * w)) return 1;
      continue;
    }
    uint32_t top = 0;
    s->stack[top++] = item->root;
    while (top) {
      const bbc__beam_node *node = &b->nodes[s->stack[--top]];
      if (!boxes_meet(p->box_lo, p->box_hi, node->lo, node->hi)) continue;
      if (node->count == 0) {
        s->stack[top++] = node->right;
        s->stack[top++] = node->left;
        continue;
      }
      for (uint32_t j = node->first; j < node->first + node->count; j++) {
        double lo[3], hi[3];
        order_box(b, j, lo, hi);
        if (!boxes_meet(p->box_lo, p->box_hi, lo, hi)) continue;
        double clipped[8];
        const double *region = WHOLE;
        if (!b->whole_triangles && !box_holds(p->box_lo, p->box_hi, lo, hi)) {
          if (!clipped_region(scene, b->order[j], p->box_lo, p->box_hi, clipped)) continue;
          region = clipped;
        }
        bbc_cell_range c;
        if (!bbc_grid_splat_polygon(grid, b->order[j], region, NULL, &c, s->row_x0, s->row_x1))
          continue;
        for (uint32_t y = c.y0; y <= c.y1; y++)
          if (s->row_x0[y - c.y0] <= s->row_x1[y - c.y0] &&
              fn(user, k, y, s->row_x0[y - c.y0], s->row_x1[y - c.y0], NULL))
            return 1;
      }
    }
  }
  return 0;
}

bbc_result bbc__beam_scratch_reserve(bbc__beam_scratch *s, const bbc__beam_receivers *b) {
  return scratch_reserve(s, b);
}

int bbc__beam_depth(const bbc__beam_receivers *b, const bbc_scene *scene, bbc__beam_scratch *s,
                    int axis, const double lo[3], const double hi[3], double *depth_lo,
                    double *depth_hi) {
  double dlo = INFINITY, dhi = -INFINITY;
  for (uint32_t k = 0; k < b->count; k++) {
    const bbc__beam_receiver *item = &b->items[k];
    if (item->root == UINT32_MAX || !boxes_meet(lo, hi, item->lo, item->hi)) continue;
    uint32_t top = 0;
    s->stack[top++] = item->root;
    while (top) {
      const bbc__beam_node *node = &b->nodes[s->stack[--top]];
      if (!boxes_meet(lo, hi, node->lo, node->hi)) continue;
      /* Nothing under the node can widen the range found. */
      if (fmax(node->lo[axis], lo[axis]) >= dlo && fmin(node->hi[axis], hi[axis]) <= dhi) continue;
      if (box_holds(lo, hi, node->lo, node->hi)) {
        /* Inside the box: the node's range on the axis is its vertices', all inside. */
        dlo = fmin(dlo, node->lo[axis]), dhi = fmax(dhi, node->hi[axis]);
        if (dlo <= lo[axis] && dhi >= hi[axis]) top = 0;
        continue;
      }
      if (node->count == 0) {
        s->stack[top++] = node->right;
        s->stack[top++] = node->left;
        continue;
      }
      for (uint32_t j = node->first; j < node->first + node->count; j++) {
        double tlo[3], thi[3];
        order_box(b, j, tlo, thi);
        if (!boxes_meet(lo, hi, tlo, thi)) continue;
        double t_lo = fmax(tlo[axis], lo[axis]), t_hi = fmin(thi[axis], hi[axis]);
        if (t_lo >= dlo && t_hi <= dhi) continue; /* its part cannot widen the range */
        double region[8];
        if (!box_holds(lo, hi, tlo, thi)) {
          /* The part in the box: its barycentrics' range maps to the axis affinely. */
          if (!clipped_region(scene, b->order[j], lo, hi, region)) continue;
          const float *v[3];
          for (int q = 0; q < 3; q++)
            v[q] = scene->positions + 3 * (size_t)scene->indices[3 * (size_t)b->order[j] + q];
          const bbc_interval p0 = bbc_interval_point(v[0][axis]);
          const bbc_interval x = bbc_interval_add(
              p0, bbc_interval_add(
                      bbc_interval_mul(bbc_interval_make(region[0], region[1]),
                                       bbc_interval_sub(bbc_interval_point(v[1][axis]), p0)),
                      bbc_interval_mul(bbc_interval_make(region[2], region[3]),
                                       bbc_interval_sub(bbc_interval_point(v[2][axis]), p0))));
          t_lo = fmax(t_lo, x.lo), t_hi = fmin(t_hi, x.hi);
          if (!(t_lo <= t_hi)) continue;
        }
        dlo = fmin(dlo, t_lo), dhi = fmax(dhi, t_hi);
      }
      if (dlo <= lo[axis] && dhi >= hi[axis]) top = 0; /* the whole range: done */
    }
    if (dlo <= lo[axis] && dhi >= hi[axis]) break;
  }
  if (!(dlo <= dhi)) return 0;
  *depth_lo = dlo, *depth_hi = dhi;
  return 1;
}
