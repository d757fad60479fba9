/* The bound of a tuple without a receiver (bounds.h, bbc_bound_beam): the light leaving
 * the last specular vertex, bounded where it may meet the receivers.
 *
 * A placeholder for now: one kept piece, the whole of T1's unit box, whose box is the
 * receivers' box and whose irradiance bound is [0, +inf]. Trivially conservative, and
 * useless for sampling (every tuple of a cell is then drawn with probability 1); it lets
 * beam tuples go through the precompute, the cache and the renderer until the real bound
 * replaces this body. */
#include <math.h>
#include <string.h>

#include "bbc/bounds.h"

bbc_result bbc_bound_beam(bbc_bounder *b, const bbc_tuple_geometry *g, const double receivers_lo[3],
                          const double receivers_hi[3], const bbc_bound_params *params,
                          int (*fn)(void *user, const bbc_beam_piece *), void *user,
                          bbc_bound_stats *stats) {
  (void)params;
  if (!b || !g || !receivers_lo || !receivers_hi || !fn) return BBC_ERR_INVALID_ARGUMENT;
  bbc_beam_piece piece;
  memset(&piece, 0, sizeof piece);
  piece.u_hi = piece.v_hi = 1;
  piece.status = BBC_PIECE_KEPT;
  piece.lambda_hi = INFINITY;
  for (int a = 0; a < 3; a++) piece.box_lo[a] = receivers_lo[a], piece.box_hi[a] = receivers_hi[a];
  piece.e_hi = INFINITY;
  if (stats) {
    stats->tuples++;
    stats->kept_pieces++;
  }
  return fn(user, &piece) ? BBC_ERR_CANCELLED : BBC_OK;
}
