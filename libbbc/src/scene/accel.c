/* Embree 3 behind bbc_accel: one triangle geometry holding every scene triangle, so
 * Embree's primitive id is the scene's triangle index.
 *
 * Cut-outs and coverage (glTF alphaMode, bbc_scene_coverage): when some material can be
 * less than fully there, the geometry gets an intersection and an occlusion filter that
 * Embree calls for every candidate hit; it drops a hit where the surface is cut out
 * (MASK), and where it is partly there (BLEND, coverage c) keeps it with probability c,
 * decided by a hash of the ray and the hit. So every query, whoever asks, sees the same
 * surfaces, and the answer stays a pure function of the ray: images do not depend on the
 * thread count. Scenes without such materials have no filter and trace as before. */
#include "bbc/accel.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

#include <embree3/rtcore.h>

#include "bbc/texture.h"
#include "report_internal.h"
#include "rng_internal.h"

struct bbc_accel {
  RTCDevice device;
  RTCScene rtc_scene;
  const bbc_scene *scene;
  unsigned char *partial; /* per material: 1 when its coverage can be below 1 */
};

static uint32_t float_bits(float x) {
  uint32_t u;
  memcpy(&u, &x, sizeof u);
  return u;
}

/* The filter of both queries (see the top of the file). The hash covers the ray (origin
 * and direction as Embree holds them) and the hit (triangle and barycentrics), so two
 * rays meeting a BLEND surface decide independently, and one ray always alike. */
static void coverage_filter(const struct RTCFilterFunctionNArguments *args) {
  const bbc_accel *accel = args->geometryUserPtr;
  const bbc_scene *scene = accel->scene;
  const unsigned N = args->N;
  const float *ray = (const float *)args->ray;
  const float *hit = (const float *)args->hit;
  for (unsigned i = 0; i < N; i++) {
    if (args->valid[i] == 0) continue;
    uint32_t triangle;
    memcpy(&triangle, &hit[5 * N + i], sizeof triangle);
    if (!accel->partial[scene->meshes[scene->triangle_mesh[triangle]].material]) continue;
    const float u = hit[3 * N + i], v = hit[4 * N + i];
    double c = bbc_scene_coverage(scene, triangle, u, v);
    if (c >= 1.0) continue;
    if (c > 0.0) {
      /* The ray's origin x, y, z and direction x, y, z (Embree's SOA layout puts tnear
       * between them), then the hit. */
      static const unsigned field[6] = {0, 1, 2, 4, 5, 6};
      uint64_t h = 0xC0FE7A6E5EEDull;
      for (int k = 0; k < 6; k++) h = bbc__mix64(h ^ float_bits(ray[field[k] * N + i]));
      h = bbc__mix64(h ^ triangle);
      h = bbc__mix64(h ^ ((uint64_t)float_bits(u) << 32 | float_bits(v)));
      if ((double)(h >> 11) * 0x1.0p-53 < c) continue;
    }
    args->valid[i] = 0;
  }
}

typedef struct device_errors {
  bbc_message_fn fn;
  void *user;
} device_errors;

static void embree_error(void *data, enum RTCError code, const char *message) {
  device_errors *errors = data;
  if (errors && errors->fn)
    bbc__report(errors->fn, errors->user, BBC_ERR_EMBREE, "Embree error %d: %s", (int)code,
                message ? message : "");
}

bbc_result bbc_accel_create(bbc_accel **out, const bbc_scene *scene, bbc_message_fn error_fn,
                            void *user) {
  *out = NULL;
  if (!scene || scene->triangle_count == 0) return BBC_ERR_INVALID_ARGUMENT;
  bbc_accel *accel = calloc(1, sizeof *accel);
  if (!accel) return BBC_ERR_OUT_OF_MEMORY;
  accel->scene = scene;
  accel->partial = calloc(scene->material_count ? scene->material_count : 1, 1);
  if (!accel->partial) {
    free(accel);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  int any_partial = 0;
  for (uint32_t i = 0; i < scene->material_count; i++)
    any_partial |= accel->partial[i] = (unsigned char)bbc_material_partial(scene, &scene->materials[i]);
  device_errors errors = {error_fn, user};
  accel->device = rtcNewDevice(NULL);
  if (!accel->device) {
    free(accel->partial);
    free(accel);
    return bbc__report(error_fn, user, BBC_ERR_EMBREE, "Embree: cannot create a device (%d)",
                       (int)rtcGetDeviceError(NULL));
  }
  rtcSetDeviceErrorFunction(accel->device, embree_error, &errors);
  accel->rtc_scene = rtcNewScene(accel->device);
  rtcSetSceneBuildQuality(accel->rtc_scene, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry geometry = rtcNewGeometry(accel->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  /* Buffers allocated by Embree carry the padding it needs for 16-byte loads of the
   * last vertex, which the scene's arrays do not. */
  float *vertices = rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                            3 * sizeof(float), scene->vertex_count);
  unsigned *indices = rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                              3 * sizeof(unsigned), scene->triangle_count);
  bbc_result result = BBC_OK;
  if (!vertices || !indices) {
    result = BBC_ERR_EMBREE;
  } else {
    memcpy(vertices, scene->positions, (size_t)scene->vertex_count * 3 * sizeof(float));
    memcpy(indices, scene->indices, (size_t)scene->triangle_count * 3 * sizeof(unsigned));
    if (any_partial) {
      rtcSetGeometryUserData(geometry, accel);
      rtcSetGeometryIntersectFilterFunction(geometry, coverage_filter);
      rtcSetGeometryOccludedFilterFunction(geometry, coverage_filter);
    }
    rtcCommitGeometry(geometry);
    rtcAttachGeometryByID(accel->rtc_scene, geometry, 0);
    rtcCommitScene(accel->rtc_scene);
    if (rtcGetDeviceError(accel->device) != RTC_ERROR_NONE) result = BBC_ERR_EMBREE;
  }
  rtcReleaseGeometry(geometry);
  /* The errors struct lives on this stack frame: detach the callback before returning. */
  rtcSetDeviceErrorFunction(accel->device, NULL, NULL);
  if (result != BBC_OK) {
    bbc_accel_free(accel);
    return result;
  }
  *out = accel;
  return BBC_OK;
}

void bbc_accel_free(bbc_accel *accel) {
  if (!accel) return;
  if (accel->rtc_scene) rtcReleaseScene(accel->rtc_scene);
  if (accel->device) rtcReleaseDevice(accel->device);
  free(accel->partial);
  free(accel);
}

static void fill_ray(struct RTCRay *ray, bbc_vec3 origin, bbc_vec3 dir, double tmin, double tmax) {
  ray->org_x = (float)origin.x;
  ray->org_y = (float)origin.y;
  ray->org_z = (float)origin.z;
  ray->dir_x = (float)dir.x;
  ray->dir_y = (float)dir.y;
  ray->dir_z = (float)dir.z;
  ray->tnear = (float)tmin;
  ray->tfar = tmax >= (double)FLT_MAX ? FLT_MAX : (float)tmax;
  ray->time = 0.0f;
  ray->mask = 0xFFFFFFFFu;
  ray->id = 0;
  ray->flags = 0;
}

int bbc_accel_intersect(const bbc_accel *accel, bbc_vec3 origin, bbc_vec3 dir, double tmin,
                        double tmax, bbc_hit *hit) {
  struct RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  struct RTCRayHit rayhit;
  fill_ray(&rayhit.ray, origin, dir, tmin, tmax);
  rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rayhit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(accel->rtc_scene, &context, &rayhit);
  if (rayhit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return 0;
  hit->t = rayhit.ray.tfar;
  hit->triangle = rayhit.hit.primID;
  hit->u = rayhit.hit.u;
  hit->v = rayhit.hit.v;
  return 1;
}

int bbc_accel_occluded(const bbc_accel *accel, bbc_vec3 origin, bbc_vec3 dir, double tmin,
                       double tmax) {
  struct RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  struct RTCRay ray;
  fill_ray(&ray, origin, dir, tmin, tmax);
  rtcOccluded1(accel->rtc_scene, &context, &ray);
  return ray.tfar < 0.0f;
}
