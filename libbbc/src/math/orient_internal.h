/* Exact orientation of four points given as floats (Shewchuk's expansion arithmetic):
 * culling decisions that must never drop a path are taken on the scene's float data
 * with no rounding and no epsilon. */
#ifndef BBC_ORIENT_INTERNAL_H
#define BBC_ORIENT_INTERNAL_H

/* The sign (-1, 0, 1) of det[b - a, c - a, d - a], computed exactly: 0 if and only if
 * the four points are coplanar. Inputs must be finite. */
int bbc__orient3d(const float a[3], const float b[3], const float c[3], const float d[3]);

#endif
