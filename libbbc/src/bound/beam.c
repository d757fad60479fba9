/* Beams (docs/beams.md): the light leaving a tuple's last specular vertex bounded without
 * a receiver. */
#include "bbc/bounds.h"

#include <math.h>
#include <string.h>

bbc_result bbc_bound_beam(bbc_bounder *bounder, const bbc_tuple_geometry *g,
                          const double receivers_lo[3], const double receivers_hi[3],
                          const bbc_bound_params *params, bbc_beam_piece_fn fn, void *user,
                          bbc_bound_stats *stats) {
  (void)bounder, (void)g, (void)params, (void)stats;
  for (int i = 0; i < 3; i++)
    if (!(receivers_lo[i] <= receivers_hi[i]) || !isfinite(receivers_lo[i]) ||
        !isfinite(receivers_hi[i]))
      return BBC_ERR_INVALID_ARGUMENT;
  bbc_beam_piece p;
  memset(&p, 0, sizeof p);
  p.u_hi = p.v_hi = p.a_hi = p.b_hi = 1;
  p.axis = -1;
  p.status = BBC_PIECE_KEPT;
  for (int i = 0; i < 3; i++) p.box_lo[i] = receivers_lo[i], p.box_hi[i] = receivers_hi[i];
  p.e_hi = INFINITY;
  return fn && fn(user, &p) ? BBC_ERR_CANCELLED : BBC_OK;
}
