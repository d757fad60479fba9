/* The precompute parameters: their defaults, their validity (R-PAR-1) and their PARM
 * encoding (format-spec Sec. 5.1). */
#include <math.h>
#include <string.h>

#include "bbc/cache.h"
#include "cache_format_internal.h"

void bbc_precompute_params_default(bbc_precompute_params *p) {
  memset(p, 0, sizeof *p);
  p->chains = BBC_CHAIN_MASK_ALL;
  p->max_level = 10;
  p->sigma = 1e-4;
  p->alpha_single = 2.0;
  p->alpha_double = 10.0;
  p->m = 1.0;
  p->grid_resolution = 512;
  p->remainder = 1;
  p->alpha_area = 100.0;
  p->max_level_double = 3;
}

uint32_t bbc__params_max_level_double(const bbc_precompute_params *p) {
  return p->max_level_double ? p->max_level_double : p->max_level;
}

uint32_t bbc__params_stored_level_double(const bbc_precompute_params *p) {
  return p->chains & BBC_CHAIN_MASK_DOUBLE ? p->max_level_double : 0;
}

int bbc__params_valid(const bbc_precompute_params *p) {
  return p->chains != 0 && (p->chains & ~BBC_CHAIN_MASK_ALL) == 0 &&
         p->max_level <= BBC__MAX_LEVEL && p->max_level_double <= BBC__MAX_LEVEL &&
         isfinite(p->sigma) && p->sigma >= 0 && isfinite(p->alpha_single) && p->alpha_single >= 1 &&
         isfinite(p->alpha_double) && p->alpha_double >= 1 && isfinite(p->m) && p->m > 0 &&
         p->grid_resolution >= 1 && p->grid_resolution <= BBC__MAX_RESOLUTION &&
         p->remainder <= 1 && p->area_lights <= 1 && p->area_double <= 1 &&
         (!p->area_double || (p->area_lights && (p->chains & BBC_CHAIN_MASK_DOUBLE))) &&
         (p->alpha_area == 0 || (isfinite(p->alpha_area) && p->alpha_area >= 1)) &&
         p->beam_receivers <= 1 && p->cell_levels <= BBC__MAX_CELL_LEVELS;
}

double bbc__params_alpha_area(const bbc_precompute_params *p) {
  return p->alpha_area > 0 ? p->alpha_area : p->alpha_double;
}

void bbc__params_encode(const bbc_precompute_params *p, uint8_t out[BBC__PARM_SIZE]) {
  memset(out, 0, BBC__PARM_SIZE);
  bbc__st32(out + 0, p->chains);
  bbc__st32(out + 4, p->max_level);
  bbc__stf64(out + 8, p->sigma);
  bbc__stf64(out + 16, p->alpha_single);
  bbc__stf64(out + 24, p->alpha_double);
  bbc__stf64(out + 32, p->m);
  bbc__st32(out + 40, p->grid_resolution);
  bbc__st32(out + 44, (p->remainder ? 1u : 0u) | (p->area_lights ? 2u : 0u) |
                          (p->area_double ? 4u : 0u) | (p->beam_receivers ? 8u : 0u));
  /* Without area lights the field is 0, so that the parameters' hash does not depend on
   * a value nothing used. */
  bbc__stf64(out + 48, p->area_lights ? p->alpha_area : 0.0);
  bbc__st32(out + 56, p->cell_levels >= 2 ? p->cell_levels : 0);
  bbc__st32(out + 60, bbc__params_stored_level_double(p));
}
