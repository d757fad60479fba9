/* Receiver grids: the parameter space of every receiver mesh, its uniform grid of cells,
 * the cell of a shading point and the cells a position bound covers (paper Sec. 6.1,
 * supplement Sec. 4.1). The rules are those of format-spec/bbc-format.md Sec. 6.
 *
 * A bbc_grid is a plain, read-only struct. One made by bbc_grid_create is owned by the
 * caller and released with bbc_grid_free; the one of an open cache
 * (bbc_cache_grid) belongs to the cache and lives until bbc_cache_close. A grid is
 * immutable, so any number of threads may use it at once. */
#ifndef BBC_GRID_H
#define BBC_GRID_H

#include "bbc/common.h"
#include "bbc/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

/* How a receiver's surface is mapped to its parameter space (spec Sec. 6). The values
 * are stored in .bbc files and never change. */
typedef enum bbc_parameterisation {
  BBC_PARAM_TEXCOORD = 0, /* TEXCOORD_0 of the file */
  BBC_PARAM_PLANAR = 1,   /* projection on the plane of a planar mesh */
  BBC_PARAM_BOX = 2,      /* projection on the two longest bounding-box axes */
  BBC_PARAM_PLANE = 3     /* a receiver plane (bbc_mesh.plane): projection on the
                             plane's two other axes; its tuples end on the plane */
} bbc_parameterisation;

/* One receiver mesh and its grid. */
typedef struct bbc_receiver {
  uint32_t mesh;               /* index into scene->meshes */
  uint32_t parameterisation;   /* a bbc_parameterisation */
  uint32_t first_triangle;     /* the mesh's scene triangles: */
  uint32_t triangle_count;     /*   [first_triangle, first_triangle + triangle_count) */
  uint32_t width, height;      /* cells along u and v */
  uint64_t first_cell;         /* global index of cell (0, 0) */
  uint64_t first_uv;           /* index of the first triangle in triangle_uv (planes:
                                  the running count, with no entries of their own) */
  double domain[4];            /* u_min, v_min, u_max, v_max in parameter space */
  double axis_u[3], axis_v[3]; /* projection axes (zero for BBC_PARAM_TEXCOORD) */
  /* BBC_PARAM_PLANE: the grid coordinates of the mesh's plane_triangle (spec Sec. 6.5),
   * not clamped to the grid; zero otherwise. Not stored: derived from the above. */
  float plane_uv[6];
  /* Global index of the receiver's first cell of level 1 (cell levels, spec Sec. 6.6);
   * not stored: derived from the grids and the level count. */
  uint64_t first_coarse_cell;
} bbc_receiver;

typedef struct bbc_grid {
  uint32_t resolution; /* cells along the longer side of a grid */
  uint32_t receiver_count;
  const bbc_receiver *receivers; /* in increasing mesh (and triangle) order */
  uint64_t cell_count;           /* over all receivers and levels */
  /* Levels of cells (spec Sec. 6.6): 1, the grids alone, or L >= 2, the grids and L - 1
   * coarser ones, level k's cells 2^k x 2^k cells of the grid. */
  uint32_t levels;
  uint64_t uv_triangle_count;    /* triangles of the receivers that are not planes */
  /* 6 floats per triangle of a receiver that is not a plane: the grid coordinates (cell
   * units) of its vertices 0, 1, 2, in [0, width] x [0, height]. Triangle t of receiver
   * r is at index r.first_uv + (t - r.first_triangle). A plane's triangles have none
   * (they are located by the point, spec Sec. 6.5). */
  const float *triangle_uv;
} bbc_grid;

/* A cell of a receiver's grid. */
typedef struct bbc_cell {
  uint32_t receiver, x, y;
} bbc_cell;

/* An inclusive rectangle of cells of one receiver. */
typedef struct bbc_cell_range {
  uint32_t receiver;
  uint32_t x0, y0, x1, y1;
} bbc_cell_range;

/* Builds the grids of every mesh of role BBC_ROLE_RECEIVER of the scene, resolution
 * cells along each grid's longer side (1..65536), choosing the parameterisation of
 * spec Sec. 6. A scene without receivers gives a grid without receivers. On failure
 * *out is NULL and the result is BBC_ERR_INVALID_ARGUMENT (resolution, NULL scene) or
 * BBC_ERR_OUT_OF_MEMORY, with a line to error_fn (may be NULL). The scene is not
 * referenced after the call. */
BBC_API bbc_result bbc_grid_create(bbc_grid **out, const bbc_scene *scene, uint32_t resolution,
                                   bbc_message_fn error_fn, void *user);

/* Releases a grid made by bbc_grid_create; NULL is allowed. Never pass the grid of a
 * cache. */
BBC_API void bbc_grid_free(bbc_grid *grid);

/* The receiver holding scene triangle `triangle`, or -1 if it is not a receiver
 * triangle. O(log receivers). Every function below that takes a triangle also takes
 * the plane of a receiver, BBC_RECEIVER_PLANE(mesh) (tuple.h), with barycentrics of the
 * mesh's plane_triangle; points of it off the grid's domain are off the mesh. */
BBC_API int64_t bbc_grid_receiver_of(const bbc_grid *grid, uint32_t triangle);

/* The cell of the point of receiver triangle `triangle` with barycentrics (b1, b2), the
 * weights of its vertices 1 and 2 (spec Sec. 6.4), and position *point. The position is
 * what locates a point of a triangle of a receiver plane (BBC_PARAM_PLANE, spec Sec.
 * 6.5; it may be NULL for other receivers and for a plane's own triangle). Returns 1 and
 * fills *out, or 0 when the triangle is not a receiver triangle, when a plane's triangle
 * comes without its point, or for a plane's own triangle when the point lies past the
 * grid (off the mesh). Points slightly outside the triangle are clamped to the grid,
 * never rejected. */
BBC_API int bbc_grid_locate(const bbc_grid *grid, uint32_t triangle, double b1, double b2,
                            const bbc_vec3 *point, bbc_cell *out);

/* The cells that a position bound [b1_lo, b1_hi] x [b2_lo, b2_hi] (barycentrics of the
 * receiver triangle; it may reach outside the triangle, or be infinite) covers, by the
 * conservative rule of spec Sec. 6.4: every point of the box that lies in the triangle
 * is located (bbc_grid_locate) in a cell of the range. NaN ends are taken as unbounded.
 * Returns 1 and fills *out, or 0 when the box misses the triangle or the triangle is
 * not a receiver triangle. */
BBC_API int bbc_grid_splat_range(const bbc_grid *grid, uint32_t triangle, double b1_lo,
                                 double b1_hi, double b2_lo, double b2_hi, bbc_cell_range *out);

/* The cells of a polygonal position bound: the box of bbc_grid_splat_range cut by
 * s_lo <= b1 + b2 <= s_hi and d_lo <= b1 - b2 <= d_hi (region = {b1_lo, b1_hi, b2_lo,
 * b2_hi, s_lo, s_hi, d_lo, d_hi}) and, for each cut {a, b, lo, hi} with |a|, |b| <= 1
 * and not a = b = 0 (cut may be NULL), lo <= a b1 + b b2 <= hi, by the same
 * conservative rule: every point of the region that lies in the triangle is located in
 * a listed cell. Fills *out with the cells' bounding range and, for each row y of it,
 * the columns x0[y - out->y0] .. x1[y - out->y0] (x0 > x1: the row is empty); the
 * arrays need room for the receiver's height. Returns 0 as bbc_grid_splat_range does. */
BBC_API int bbc_grid_splat_polygon(const bbc_grid *grid, uint32_t triangle, const double region[8],
                                   const double cut[2][4], bbc_cell_range *out, uint32_t *x0,
                                   uint32_t *x1);

/* The global index of a cell: receivers[r].first_cell + y * width + x. */
static inline uint64_t bbc_grid_cell_index(const bbc_grid *grid, bbc_cell cell) {
  const bbc_receiver *r = &grid->receivers[cell.receiver];
  return r->first_cell + (uint64_t)cell.y * r->width + cell.x;
}

/* Level k (0 <= k < grid->levels) of receiver r: its first global cell index, and its
 * width and height, ceil(width / 2^k) x ceil(height / 2^k) (spec Sec. 6.6). */
static inline uint64_t bbc_grid_level(const bbc_grid *grid, uint32_t receiver, uint32_t level,
                                      uint32_t *width, uint32_t *height) {
  const bbc_receiver *r = &grid->receivers[receiver];
  uint64_t first = r->first_coarse_cell;
  for (uint32_t j = 1; j < level; j++)
    first += (((uint64_t)(r->width - 1) >> j) + 1) * (((uint64_t)(r->height - 1) >> j) + 1);
  *width = ((r->width - 1) >> level) + 1;
  *height = ((r->height - 1) >> level) + 1;
  return level == 0 ? r->first_cell : first;
}

/* The global index of the cell of level k holding cell `cell` of the grid (level 0). */
static inline uint64_t bbc_grid_level_cell(const bbc_grid *grid, bbc_cell cell, uint32_t level) {
  uint32_t w, h;
  const uint64_t first = bbc_grid_level(grid, cell.receiver, level, &w, &h);
  return first + (uint64_t)(cell.y >> level) * w + (cell.x >> level);
}

/* A short name of a parameterisation: "texcoord", "planar", "box" or "unknown". */
BBC_API const char *bbc_parameterisation_name(uint32_t parameterisation);

#ifdef __cplusplus
}
#endif

#endif
