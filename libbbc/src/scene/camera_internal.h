/* Camera placement shared by the scene loader and the camera animation (camera.c). */
#ifndef BBC_CAMERA_INTERNAL_H
#define BBC_CAMERA_INTERNAL_H

#include "bbc/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

/* m = T * R * S, column-major (glTF 2.0, section 3.5.3); q is a unit quaternion
 * (x, y, z, w). */
void bbc__trs_matrix(const double t[3], const double q[4], const double s[3], double m[16]);

/* The camera's position and frame from its node's world matrix: x right, y up, looking
 * along -z; scale is removed and shear squeezed out by Gram-Schmidt so u, v, w are
 * orthonormal and right-handed. Returns 0 (out unchanged) for a degenerate matrix. */
int bbc__camera_frame(const double world[16], bbc_camera *out);

/* One animated node property, copied from the file (see bbc__gltf_channel). */
typedef struct bbc__channel {
  int path;          /* 0 translation, 1 rotation, 2 scale */
  int interpolation; /* 0 LINEAR, 1 STEP, 2 CUBICSPLINE */
  uint32_t key_count; /* 0: not animated */
  float *times, *values;
} bbc__channel;

typedef struct bbc__node_motion {
  int has_matrix;
  double matrix[16];
  double translation[3], rotation[4], scale[3];
  bbc__channel channels[3];
} bbc__node_motion;

/* What places a camera over time: the nodes from the root down to the camera's. */
typedef struct bbc__camera_motion bbc__camera_motion;
struct bbc__camera_motion {
  uint32_t path_length;
  bbc__node_motion *path;
};

void bbc__camera_motion_free(bbc__camera_motion *motion, uint32_t count);

#ifdef __cplusplus
}
#endif

#endif
