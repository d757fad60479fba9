/* Receiver grids, internal: what the cache reader shares with bbc_grid_create. */
#ifndef BBC_GRID_INTERNAL_H
#define BBC_GRID_INTERNAL_H

#include "bbc/grid.h"

/* Fills r->plane_uv from its parameterisation, domain, width and height (spec Sec. 6.5):
 * the grid coordinates of the plane triangle of a BBC_PARAM_PLANE receiver, zero for
 * others. */
void bbc__grid_plane_coords(bbc_receiver *r);

/* Gives the grid `levels` levels of cells (1..BBC__MAX_LEVELS; spec Sec. 6.6): sets each
 * receiver's first_coarse_cell (receivers is the grid's own array) and the cell count,
 * the grids' cells first, then each receiver's levels 1, 2, ... in receiver order. */
void bbc__grid_set_levels(bbc_grid *g, bbc_receiver *receivers, uint32_t levels);

/* The level count of a cache with beam receivers at grid resolution `resolution`: the
 * coarsest level's cells are 2^(L-1) >= resolution / 8 cells of the grid (one level when
 * that is 1). */
uint32_t bbc__grid_beam_levels(uint32_t resolution);

/* Whether a tuple may end at `receiver` (spec R-TUP-1): a triangle of a receiver that is
 * not a plane, or the plane of a receiver that is one. */
int bbc__grid_tuple_end(const bbc_grid *grid, uint32_t receiver);

#endif
