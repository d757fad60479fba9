/* Rendering: a unidirectional path tracer with next-event estimation, the integrator
 * the caustic estimator plugs into. */
#ifndef BBC_RENDER_H
#define BBC_RENDER_H

#include "bbc/accel.h"
#include "bbc/image.h"
#include "bbc/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Options; a zero-initialised struct means the defaults given per field. */
typedef struct bbc_render_options {
  uint32_t spp;          /* samples per pixel; 0 = 16 unless time_limit is set */
  double time_limit;     /* seconds of rendering; 0 = none. With both spp and
                            time_limit, whichever is reached first stops. */
  uint32_t max_depth;    /* maximum number of segments of a path from the camera
                            to a light, the connection to the light included;
                            0 = 16 */
  int threads;           /* 0 = every core */
  uint64_t seed;         /* the same seed gives the same image */
  int no_fresnel;        /* dielectrics always transmit (reflect only on total
                            internal reflection), the paper's assumption */
  bbc_progress_fn progress; /* optional; called between passes on the calling thread
                               with samples per pixel done / planned (planned is 0
                               under a pure time limit) */
  void *progress_user;
} bbc_render_options;

typedef struct bbc_render_stats {
  double seconds;       /* wall time of rendering */
  uint32_t spp;         /* samples per pixel completed */
  uint64_t samples;     /* camera samples traced */
  uint64_t rays;        /* closest-hit plus occlusion rays */
  int threads;          /* threads used */
} bbc_render_stats;

/* Renders the scene's camera into image (whose size sets the resolution and the
 * aspect ratio, see bbc_camera_ray). The image receives the mean radiance per pixel (box
 * filter). accel must have been built for scene. stats may be NULL. Deterministic:
 * with an spp budget the image is bit-identical for any thread count. Returns
 * BBC_ERR_CANCELLED if the progress callback asks to stop; the image then holds the
 * mean of the completed passes. */
BBC_API bbc_result bbc_render(const bbc_scene *scene, const bbc_accel *accel,
                              const bbc_render_options *options, bbc_image *image,
                              bbc_render_stats *stats);

/* The primary ray through film position (px, py) in pixels of a width x height film
 * ((0,0) is the top-left corner). The film's aspect ratio is width / height and the
 * camera's yfov spans its height; dir is unit length. */
BBC_API void bbc_camera_ray(const bbc_camera *camera, uint32_t width, uint32_t height,
                            double px, double py, bbc_vec3 *origin, bbc_vec3 *dir);

#ifdef __cplusplus
}
#endif

#endif
