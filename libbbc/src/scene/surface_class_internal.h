/* Surface classes of glTF materials (surface_class.c). */
#ifndef BBC_SURFACE_CLASS_INTERNAL_H
#define BBC_SURFACE_CLASS_INTERNAL_H

#include "bbc/scene.h"

/* How far from ideal a roughness, metallic or transmission value may be and still count
 * as ideal: a surface whose roughness is below it is smooth (the receivers' glossy model
 * cannot go below it, bsdf.h), a metallic or transmission within it of 1 is a metal or
 * fully transmissive, within it of 0 is not. Textures store 8-bit, often lossy values:
 * an exact test would make a texture's "0.02" or a JPEG's 254 rough. */
#define BBC_IDEAL_TOLERANCE 0.05

/* The class of a surface whose metallic, roughness and transmission each lie in the
 * given range {lo, hi} (a single value when lo = hi): a mirror when every combination
 * is smooth and metal, a dielectric when every one is smooth, not metal and
 * transmissive, otherwise a receiver (BBC_MATERIAL_DIFFUSE), with *mixed set when some
 * combination in the ranges could be ideal (the values disagree about the class). */
bbc_material_type bbc__class_of_ranges(const double metallic[2], const double roughness[2],
                                       const double transmission[2], int *mixed);

/* The least and greatest value of `channel` (0 R, 1 G, 2 B) over every texel a lookup
 * of texture tex, through the transform x (bbc_texture_use.uv_transform), can read at a
 * point of the triangle with TEXCOORD_0 uv[0..2]: those of the bounding box of its
 * texture coordinates, widened by a texel for bilinear filtering, wrapped as its sampler
 * says (every texel when the box spans the texture). */
void bbc__texture_range(const bbc_texture *tex, const double x[6], const float *uv[3],
                        int channel, double *lo, double *hi);

#endif
