/* Internal entry points of the exact tracer (bbc/specular_path.h). */
#ifndef BBC_SPECULAR_PATH_INTERNAL_H
#define BBC_SPECULAR_PATH_INTERNAL_H

#include "bbc/specular_path.h"

/* bbc_specular_path_trace up to the last specular vertex only: x1, n1 and, for two
 * vertices, x2, u2 and d u2 / d u1, with the flags met on the way there except
 * BBC_PATH_GEOMETRIC_SIDE (not checked); nothing at the last vertex (not even its
 * shading normal n2), of the last scattering or of x_k. complete is 1 when the last
 * specular vertex was reached. The reduced Newton iteration needs no more (its residual
 * at the last vertex points toward x_k itself, with the normal it interpolates there). */
bbc_result bbc__specular_path_trace_to_last_vertex(const bbc_path_geometry *g, double u, double v,
                                                   bbc_specular_path *out);

#endif
