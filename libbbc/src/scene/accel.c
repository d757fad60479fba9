/* Embree 3 behind bbc_accel: one triangle geometry holding every scene triangle, so
 * Embree's primitive id is the scene's triangle index. */
#include "bbc/accel.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

#include <embree3/rtcore.h>

#include "report_internal.h"

struct bbc_accel {
  RTCDevice device;
  RTCScene rtc_scene;
  const bbc_scene *scene;
};

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
  device_errors errors = {error_fn, user};
  accel->device = rtcNewDevice(NULL);
  if (!accel->device) {
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
