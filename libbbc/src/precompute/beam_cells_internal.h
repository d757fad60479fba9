/* The cells a beam piece reaches (bbc_bound_beam; beam receivers, docs/receivers.md):
 * the cells of every receiver triangle not on a receiver plane that the piece's
 * world-space box meets. A BVH per such receiver finds the triangles whose boxes meet
 * it; a triangle inside the box gives the cells of its whole footprint in the grid
 * (bbc_grid_splat_polygon of the triangle), another one those of the part of it in the
 * box (clipped in its barycentrics, conservatively), none when that part is empty. A
 * piece whose box holds the receiver's whole box takes every cell any triangle of the
 * receiver covers at once (the receiver's mask). */
#ifndef BBC_BEAM_CELLS_INTERNAL_H
#define BBC_BEAM_CELLS_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "bbc/bounds.h"
#include "bbc/grid.h"
#include "bbc/scene.h"

typedef struct bbc__beam_node {
  double lo[3], hi[3];
  uint32_t first, count; /* leaf: triangles order[first, first + count) */
  uint32_t left, right;  /* inner node: children (count == 0) */
} bbc__beam_node;

/* One receiver that is not a plane. */
typedef struct bbc__beam_receiver {
  uint32_t receiver; /* its index in the grid */
  double lo[3], hi[3];
  uint32_t root;               /* its BVH's root in `nodes` */
  uint32_t mx0, my0, mx1, my1; /* the rectangle of its mask (mx0 > mx1: none) */
  uint8_t *mask;               /* per cell of the rectangle, 1 when a triangle's footprint
                                  covers it */
} bbc__beam_receiver;

typedef struct bbc__beam_receivers {
  double lo[3], hi[3]; /* the box of every triangle of these receivers */
  uint32_t count;
  bbc__beam_receiver *items;
  bbc__beam_node *nodes;
  uint32_t node_count;
  uint32_t *order;
  float *boxes; /* per position of `order`, its triangle's box: lo[3], hi[3] */
  uint32_t max_width, max_height; /* the largest grid of these receivers */
  size_t bytes;                   /* what this holds */
  int whole_triangles;            /* 1: no clipping, every triangle met gives its whole
                                     footprint (for comparisons; 0 by default) */
} bbc__beam_receivers;

/* Per-thread working memory of the walks below. */
typedef struct bbc__beam_scratch {
  uint32_t *row_x0, *row_x1, *stack;
  size_t rows, stack_capacity;
} bbc__beam_scratch;

/* Builds the BVHs and masks of the grid's receivers that are not planes (none: count 0
 * and an empty box). */
bbc_result bbc__beam_receivers_init(bbc__beam_receivers *b, const bbc_scene *scene,
                                    const bbc_grid *grid);
void bbc__beam_receivers_free(bbc__beam_receivers *b);
void bbc__beam_scratch_free(bbc__beam_scratch *s);

/* The range [*depth_lo, *depth_hi] along `axis` of the receivers' triangles inside the
 * box lo..hi (of each triangle meeting it, the range of its part in the box, clipped as
 * for the cells), or 0 when no triangle meets it. The scratch must be reserved. */
int bbc__beam_depth(const bbc__beam_receivers *b, const bbc_scene *scene, bbc__beam_scratch *s,
                    int axis, const double lo[3], const double hi[3], double *depth_lo,
                    double *depth_hi);

/* Calls fn for each row of cells piece p reaches: receiver item k (b->items[k]), row y, columns
 * x0..x1, and when not NULL the receiver's mask row (indexed by column; only columns whose mask is
 * 1 are reached). A cell may be visited more than once (from several triangles). Returns 1 as soon
 * as fn returns non-zero, else 0. The scratch must be reserved (bbc__beam_scratch_reserve). */
typedef int (*bbc__beam_row_fn)(void *user, uint32_t k, uint32_t y, uint32_t x0, uint32_t x1,
                                const uint8_t *mask);
int bbc__beam_piece_rows(const bbc__beam_receivers *b, const bbc_scene *scene, const bbc_grid *grid,
                         const bbc_beam_piece *p, bbc__beam_scratch *s, bbc__beam_row_fn fn,
                         void *user);
bbc_result bbc__beam_scratch_reserve(bbc__beam_scratch *s, const bbc__beam_receivers *b);

#endif
