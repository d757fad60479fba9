/* The bound of a tuple without a receiver (bounds.h, bbc_bound_beam): the light leaving
 * the last specular vertex, bounded where it may meet the receivers.
 *
 * A placeholder for now: one kept piece, the whole of T1's unit box, whose box is the
 * receivers' box and whose irradiance bound is [0, +inf]. Trivially conservative, and
 * useless for sampling (every tuple of a cell is then drawn with probability 1); it lets
 * beam tuples go through the precompute, the cache and the renderer until the real bound
 * replaces this body. */
#include <math.h>

#include "bbc/bounds.h"

bbc_result bbc_bound_beam(bbc_bounder *b, const bbc_tuple_geometry *g,
                          const double receivers_lo[3], const double receivers_hi[3],
                          const bbc_bound_params *params,
                          int (*fn)(void *user, const bbc_beam_piece *), void *user,
                          bbc_bound_stats *stats) {
  (void)params;
  if (!b || !g || !receivers_lo || !receivers_hi || !fn) return BBC_ERR_INVALID_ARGUMENT;
  bbc_beam_piece piece = {0, 1, 0, 1, 0, BBC_PIECE_KEPT, 0, INFINITY, 0,
                          {receivers_lo[0], receivers_lo[1], receivers_lo[2]},
                          {receivers_hi[0], receivers_hi[1], receivers_hi[2]},
                          0, INFINITY};
  if (stats) {
    stats->tuples++;
    stats->kept_pieces++;
  }
  return fn(user, &piece) ? BBC_ERR_CANCELLED : BBC_OK;
}
