/* Receiver grids, internal: what the cache reader shares with bbc_grid_create. */
#ifndef BBC_GRID_INTERNAL_H
#define BBC_GRID_INTERNAL_H

#include "bbc/grid.h"

/* Fills r->plane_uv from its parameterisation, domain, width and height (spec Sec. 6.5):
 * the grid coordinates of the plane triangle of a BBC_PARAM_PLANE receiver, zero for
 * others. */
void bbc__grid_plane_coords(bbc_receiver *r);

/* Whether a tuple may end at `receiver` (spec R-TUP-1): a triangle of a receiver that is
 * not a plane, or the plane of a receiver that is one. */
int bbc__grid_tuple_end(const bbc_grid *grid, uint32_t receiver);

#endif
