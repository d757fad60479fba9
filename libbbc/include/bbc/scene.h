/* Scenes: triangles in world space with materials, roles, lights and a camera, loaded
 * from glTF 2.0 (.gltf or .glb).
 *
 * A bbc_scene is a plain struct (in the manner of cgltf): every field is read-only to
 * the caller, the whole object is owned by whoever loaded it and released with
 * bbc_scene_free. It is immutable after loading, so any number of threads may read it
 * at once. */
#ifndef BBC_SCENE_H
#define BBC_SCENE_H

#include "bbc/common.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum bbc_material_type {
  BBC_MATERIAL_DIFFUSE = 0,   /* a receiver: Lambertian, or glossy (bsdf.h) */
  BBC_MATERIAL_MIRROR = 1,    /* perfect conductor, reflectance = base_color */
  BBC_MATERIAL_DIELECTRIC = 2 /* perfectly smooth glass/water with index ior */
} bbc_material_type;

/* How a texture coordinate outside [0, 1] is brought back (glTF sampler wrapS/wrapT). */
typedef enum bbc_wrap {
  BBC_WRAP_REPEAT = 0, /* the fractional part (glTF 10497, the default) */
  BBC_WRAP_CLAMP = 1,  /* clamped to the edge texels (33071) */
  BBC_WRAP_MIRROR = 2  /* repeated, every other copy mirrored (33648) */
} bbc_wrap;

/* A decoded texture, rows from the top of the image (texture coordinate v = 0), with its
 * sampler's wrap modes and magnification filter. A base colour texture holds linear RGB
 * (the file's sRGB decoded with the exact IEC 61966-2-1 curve); a data texture
 * (metallic-roughness, transmission) the stored values over their maximum (255 or
 * 65535), undecoded, as glTF says. */
typedef struct bbc_texture {
  uint32_t width, height;
  float *rgb; /* 3 floats per texel, row-major */
  /* The alpha channel, 1 float per texel in [0, 1] (linear: glTF alpha is never
   * sRGB-encoded), or NULL: kept only when a MASK or BLEND material uses the texture and
   * some texel is not opaque; NULL reads as alpha 1. */
  float *alpha;
  bbc_wrap wrap_s, wrap_t;
  int nearest; /* magFilter NEAREST; otherwise bilinear (no mipmaps: see texture.h) */
} bbc_texture;

/* A material's use of a texture: 1 + its index into scene->textures, or 0 for none; and
 * the map from TEXCOORD_0 to texture coordinates, (s, t) = (m[0] u + m[1] v + m[2],
 * m[3] u + m[4] v + m[5]), from KHR_texture_transform (the identity without it). */
typedef struct bbc_texture_use {
  uint32_t texture;
  double uv_transform[6];
} bbc_texture_use;
/* glTF alphaMode: what a material's alpha (baseColorFactor's fourth component times its
 * base colour texture's alpha channel) does. The values are fixed. */
typedef enum bbc_alpha_mode {
  BBC_ALPHA_OPAQUE = 0, /* alpha is ignored (the glTF default) */
  BBC_ALPHA_MASK = 1,   /* the surface is there where alpha >= alpha_cutoff and is cut out
                           elsewhere: no ray, shadow ray or specular path meets it */
  BBC_ALPHA_BLEND = 2   /* alpha is coverage: a ray meets the surface with probability
                           alpha (docs/materials.md) */
} bbc_alpha_mode;

typedef struct bbc_material {
  char name[64];
  bbc_material_type type;
  float base_color[3]; /* linear RGB: baseColorFactor; times the texture where it has one */
  float ior;           /* dielectrics only; 1.5 when absent */
  float emission[3];   /* emitted radiance (W/sr/m^2); zero for non-emitters */
  /* The base colour texture: 1 + its index into scene->textures, or 0 for none (so a
   * zeroed material has none; also 0 when its image could not be read: the loader
   * warns, and the surface has the factor alone, as under a white texture).
   * uv_transform maps TEXCOORD_0 to texture coordinates,
   * (s, t) = (m[0] u + m[1] v + m[2], m[3] u + m[4] v + m[5]), from
   * KHR_texture_transform (the identity without it); unused without a texture. */
  uint32_t base_color_texture;
  double uv_transform[6];
  /* Receivers (BBC_MATERIAL_DIFFUSE) only. glossy 0: Lambertian, albedo = base colour
   * (glTF's metallic 0 with roughness 1, and any zeroed material); glossy 1: glTF's
   * metallic-roughness BRDF with these factors (bbc/bsdf.h). */
  int glossy;
  float roughness, metallic;
  /* glTF's metallicRoughnessTexture (roughness = factor x G, metallic = factor x B) and
   * transmissionTexture (transmission = factor x R). With either, the material's surface
   * class (type) is decided per triangle from the texels its UVs cover, and a glTF
   * material whose triangles fall in several classes becomes one bbc material per class
   * (docs/materials.md). A receiver with a metallic-roughness texture is glossy with
   * roughness and metallic (then the factors) times the texture at each point. */
  bbc_texture_use metallic_roughness, transmission;
  /* glTF's emissiveTexture: the emitted radiance at a point is emission times it there
   * (bbc_scene_emission in texture.h). */
  bbc_texture_use emissive;
  /* The glTF material this one was read from; -1 for the default material of
   * primitives without one. */
  int32_t source;
  /* Cut-outs and coverage (bbc_scene_coverage in texture.h): the alpha mode, glTF's
   * alphaCutoff (MASK only; 0.5 when absent) and baseColorFactor's alpha. */
  bbc_alpha_mode alpha_mode;
  float alpha_cutoff, alpha;
  /* Dielectrics only: the Beer-Lambert absorption coefficient per scene unit of length
   * inside the volume, -ln(attenuationColor) / attenuationDistance of
   * KHR_materials_volume: light that travels a length x inside is multiplied by
   * exp(-absorption x). 0 without attenuation (no attenuationDistance, which glTF reads
   * as infinite, or an attenuationColor channel of 1); FLT_MAX for a channel whose
   * attenuationColor is 0 (opaque; the loader warns). Besides, each refraction through
   * a dielectric's surface, entering or leaving, multiplies the light by its base_color
   * (at most 1), glTF's tint of transmission; its reflections are not tinted
   * (docs/materials.md). */
  float absorption[3];
} bbc_material;

/* What a mesh does for caustics: casters are the specular surfaces light is bounced
 * through, receivers carry the caustic (and its cache grid), "none" is only traced. */
typedef enum bbc_role { BBC_ROLE_CASTER = 0, BBC_ROLE_RECEIVER = 1, BBC_ROLE_NONE = 2 } bbc_role;

/* One glTF primitive, flattened to world space. Its vertices are
 * [first_vertex, first_vertex + vertex_count) and its triangles
 * [first_triangle, first_triangle + triangle_count) of the scene arrays. */
typedef struct bbc_mesh {
  char name[64];
  uint32_t first_vertex, vertex_count;
  uint32_t first_triangle, triangle_count;
  uint32_t material;
  bbc_role role;
  int has_normals; /* vertex normals from the file; otherwise the flat normal is stored */
  int has_uvs;     /* TEXCOORD_0 from the file; otherwise uvs are zero */
  /* Dielectrics only (else 0 and 1): closed is 1 when every edge is shared by exactly
   * two of its triangles (a watertight volume); outward is +1 when the winding normals
   * of a closed mesh point to its front, -1 when not. The front of a closed mesh is its
   * outside, except for a cavity's wall (a closed mesh inside another closed dielectric
   * whose vertex normals point into it, the inner surface of a hollow glass), whose
   * front is its inside (cavity, at the end of the struct, is then 1). An open mesh's
   * front is where its vertex normals point. */
  int closed, outward;
  /* Receivers whose every vertex has one same coordinate x, y or z (a floor, a wall or
   * a table top as files store them): plane is 1 + that axis (1, 2 or 3), else 0.
   * The tuples of such a receiver end on its plane, not on its triangles (tuple.h), so
   * their number does not grow with its tessellation. plane_triangle is then a triangle
   * of that plane holding the whole mesh, on which the bounds are taken: on the plane's
   * two other axes a < b, with [lo_a, lo_a + La] x [lo_b, lo_b + Lb] the mesh's bounding
   * rectangle and L = max(La, Lb), the points (lo_a, lo_b), (lo_a + 2L, lo_b) and
   * (lo_a, lo_b + 2L) (format-spec Sec. 6.5). */
  int plane;
  bbc_vec3 plane_triangle[3];
  int cavity; /* dielectrics: 1 for a cavity's wall (above), else 0 */
} bbc_mesh;

/* How KHR_lights_punctual intensities are read. The glTF specification gives point and
 * spot lights in candela (lm/sr) and directional lights in lux (lm/m^2); bbc renders
 * radiometric quantities (W/sr, W/m^2) and converts with BBC_LUMENS_PER_WATT. A scene
 * whose numbers are already radiometric says so with the asset-level
 * asset.extras.bbc.light_units: "radiometric" (or "photometric", the default). */
typedef enum bbc_light_units {
  BBC_LIGHT_UNITS_FILE = 0,        /* as the file says; photometric when it says nothing */
  BBC_LIGHT_UNITS_PHOTOMETRIC = 1, /* candela and lux, whatever the file says */
  BBC_LIGHT_UNITS_RADIOMETRIC = 2  /* W/sr and W/m^2, whatever the file says */
} bbc_light_units;

/* The luminous efficacy used to turn lumens into watts (that of 555 nm light, the SI
 * definition of the candela; also what Blender's glTF exporter multiplies by). */
#define BBC_LUMENS_PER_WATT 683.0

/* A glTF light intensity in the given units (BBC_LIGHT_UNITS_PHOTOMETRIC or
 * BBC_LIGHT_UNITS_RADIOMETRIC) as a radiometric one: candela to W/sr for point and
 * spot lights, lux to W/m^2 for directional ones. The one place units are converted. */
static inline double bbc_light_radiometric(double intensity, bbc_light_units units) {
  return units == BBC_LIGHT_UNITS_RADIOMETRIC ? intensity : intensity / BBC_LUMENS_PER_WATT;
}


/* The kinds of KHR_lights_punctual light. The values are fixed. */
typedef enum bbc_light_kind {
  BBC_LIGHT_POINT = 0,      /* emits equally in every direction */
  BBC_LIGHT_SPOT = 1,       /* a point light with the glTF cone falloff (bbc_light_falloff) */
  BBC_LIGHT_DIRECTIONAL = 2, /* a sun: parallel light along `direction`, from infinity */
  BBC_LIGHT_AREA = 3         /* an emissive triangle (bbc_scene_area_light): not a glTF
                                punctual light, but a light of the cache (docs/lights.md) */
} bbc_light_kind;

/* How a light emits, apart from its position and brightness: what the bounds, the exact
 * paths and the path tracer need to know of its kind. Zero-initialised it is a point
 * light. */
typedef struct bbc_light_model {
  bbc_light_kind kind;
  bbc_vec3 direction; /* spot: the cone's axis; directional: the direction the light
                         travels (the node's -Z); unit length; zero for point lights */
  /* Spot only, glTF's reference falloff (KHR_lights_punctual): with cd the cosine between
   * `direction` and the direction to the lit point, t = clamp((cd - cos_outer) scale, 0, 1)
   * and the intensity is multiplied by t^2, where
   * scale = 1 / max(0.001, cos(innerConeAngle) - cos(outerConeAngle)). */
  double cos_outer, cone_scale;
  /* Area only: the emissive triangle's vertices q[0..2] and its front normal
   * emitter_normal = +-(q1 - q0) x (q2 - q0) (computed in double, not normalised; its
   * length is twice the area), turned to the side its vertex normals point to, the side
   * it emits to. A point of the emitter is q0 + a (q1 - q0) + a b (q2 - q1) for (a, b) in
   * [0, 1]^2 (the map that takes the unit square onto the triangle; a = sqrt(r1), b = r2
   * for uniform r1, r2 is uniform by area). */
  bbc_vec3 emitter[3];
  bbc_vec3 emitter_normal;
  /* Directional only: the sun's angular diameter delta in radians, from the glTF light's
   * extras.bbc.angular_diameter (degrees, 0 to BBC_SUN_MAX_ANGULAR_DIAMETER). 0, the
   * default, is a delta sun: parallel light along `direction`. With delta > 0 the sun is
   * a disk at infinity: every direction within delta / 2 of -direction brings the same
   * radiance L = E / (pi sin^2(delta / 2)), E the light's intensity, so that E stays the
   * irradiance on a surface facing the sun (bbc_light_sun_radiance_scale). The cache's
   * bounds and the caustic estimator use the centre direction alone; the path tracer
   * samples and hits the disk (docs/lights.md). */
  double angular_diameter;
} bbc_light_model;

/* The largest angular diameter the loader accepts for a sun, in degrees (the real sun's
 * is 0.53). A light source wider than this is no sun: make it an emissive mesh. */
#define BBC_SUN_MAX_ANGULAR_DIAMETER 20.0

/* L / E for a sun of angular diameter `delta` (radians, > 0): the radiance of its disk
 * per unit of irradiance on a surface facing it, 1 / (pi sin^2(delta / 2)); the integral
 * of cos(theta) over the cone of half-angle delta / 2 is pi sin^2(delta / 2). 0 for
 * delta <= 0 (a delta sun has no radiance). */
BBC_API double bbc_light_sun_radiance_scale(double delta);

/* A light of KHR_lights_punctual (the array keeps the historical name point_lights).
 * Point and spot lights: intensity is the radiant intensity (W/sr) per RGB channel,
 * glTF intensity x color in radiometric units (bbc_light_radiometric), at position.
 * Directional lights (suns): intensity is the irradiance (W/m^2) on a surface facing the
 * light, likewise; position is the node's and unused. */
typedef struct bbc_point_light {
  bbc_vec3 position;
  float intensity[3];
  uint32_t medium; /* 0: in air; m + 1: inside the material of dielectric mesh m (suns: 0) */
  bbc_light_model model;
} bbc_point_light;

/* The spot falloff of `model` (1 for other kinds) for the unit direction w from the
 * light to the lit point: glTF's reference curve above, in [0, 1], non-decreasing in
 * the cosine w . direction and 0 on and outside the outer cone. */
BBC_API double bbc_light_falloff(const bbc_light_model *model, bbc_vec3 w);

/* A pinhole camera looking along -w with up v and right u (orthonormal, world space). */
typedef struct bbc_camera {
  char name[64]; /* the glTF camera's name, else its node's, else "camera N" */
  bbc_vec3 position;
  bbc_vec3 u, v, w;
  double yfov;   /* vertical field of view, radians */
  double aspect; /* width / height of the film */
  uint32_t width, height;
  /* Whether a glTF animation moves the camera (its node or an ancestor), and the times
   * (seconds) of its first and last keys; the fields above are its rest placement. */
  int animated;
  double time_start, time_end;
} bbc_camera;

/* The primary ray through film position (px, py) in pixels of a width x height film
 * ((0,0) is the top-left corner). The film's aspect ratio is width / height and the
 * camera's yfov spans its height; dir is unit length. */
BBC_API void bbc_camera_ray(const bbc_camera *camera, uint32_t width, uint32_t height, double px,
                            double py, bbc_vec3 *origin, bbc_vec3 *dir);

struct bbc__camera_motion; /* internal: what moves each camera */

typedef struct bbc_scene {
  char path[1024]; /* the file it was loaded from */

  /* Vertices in world space. positions/normals: 3 floats each; uvs: 2 floats each.
   * Normals are unit length (vertex normals, or the triangle's flat normal when the
   * mesh has none; vertices of flat meshes are not shared between triangles). */
  uint32_t vertex_count;
  float *positions;
  float *normals;
  float *uvs;

  /* Triangles: 3 vertex indices each (into the scene arrays), and the mesh each one
   * belongs to. Meshes come in node order; within a mesh, vertices and triangles are
   * in a canonical order that depends on the geometry only, not on the file's order
   * (format-spec Sec. 8), so that re-exports keep the scene's identity. */
  uint32_t triangle_count;
  uint32_t *indices;
  uint32_t *triangle_mesh;

  uint32_t mesh_count;
  bbc_mesh *meshes;
  uint32_t material_count;
  bbc_material *materials;
  uint32_t texture_count;
  bbc_texture *textures; /* those base colour textures use, in file order */

  uint32_t point_light_count;
  bbc_point_light *point_lights;
  /* The lights of a cache are the punctual lights, then (for caches with area lights,
   * bbc_precompute_params.area_lights) the emissive triangles: a tuple's light index
   * l >= point_light_count names emitters[l - point_light_count]
   * (bbc_scene_area_light). */

  /* Emissive triangles (area lights), with the cumulative area-times-power
   * distribution used to sample them. */
  uint32_t emitter_count;
  uint32_t *emitters;   /* triangle indices */
  double *emitter_cdf;  /* emitter_count entries, last one 1 */
  double emitter_power; /* sum of area x mean radiance x pi */

  bbc_camera camera; /* the first camera, cameras[0] */
  /* Every node with a camera in the default scene, in a depth-first walk (roots in
   * order, a node before its children). */
  uint32_t camera_count;
  bbc_camera *cameras;
  struct bbc__camera_motion *camera_motion; /* internal, one per camera */

  /* The media on the two sides of each dielectric triangle (docs/materials.md, "Media"):
   * media[2 t] lies in front of triangle t and media[2 t + 1] behind it, each 0 for air,
   * m + 1 for the material of dielectric mesh m, or mesh_count + 1 + m for the air
   * enclosed by the cavity's wall m (bbc_mesh.cavity). NULL when no two dielectric
   * meshes' bounding boxes meet: then every dielectric has air in front and its own mesh
   * behind. */
  uint32_t *media;

  /* The units the file's KHR_lights_punctual intensities were read in (never
   * BBC_LIGHT_UNITS_FILE); the light fields above are radiometric either way. */
  bbc_light_units light_units;
} bbc_scene;


typedef struct bbc_scene_options {
  bbc_message_fn error_fn;   /* optional: details of a failure */
  bbc_message_fn warning_fn; /* optional: e.g. "material X treated as diffuse" */
  void *user;                /* passed to both callbacks */
  bbc_light_units light_units; /* 0 (BBC_LIGHT_UNITS_FILE) unless overridden */
} bbc_scene_options;

/* Loads a .gltf or .glb file. On success *out owns the scene; on failure *out is NULL,
 * the result says what went wrong (BBC_ERR_IO, BBC_ERR_GLTF, BBC_ERR_SCENE,
 * BBC_ERR_OUT_OF_MEMORY) and error_fn gets one line naming the file and the problem.
 * options may be NULL. */
BBC_API bbc_result bbc_scene_load(bbc_scene **out, const char *path,
                                  const bbc_scene_options *options);

/* Camera `index` (into scene->cameras) placed as its glTF animation has it at `time`
 * seconds: translation, rotation and scale channels of its node and of the node's
 * ancestors, LINEAR (rotations by spherical interpolation), STEP or CUBICSPLINE;
 * before the first key and after the last one the end keys hold. A camera without
 * animation is returned as it is. BBC_ERR_INVALID_ARGUMENT for an index out of range or
 * a non-finite time, BBC_ERR_SCENE when the animated matrix is degenerate (a zero
 * scale). */
BBC_API bbc_result bbc_scene_camera_at(const bbc_scene *scene, uint32_t index, double time,
                                       bbc_camera *out);

/* Releases a scene; NULL is allowed. */
BBC_API void bbc_scene_free(bbc_scene *scene);

/* The emitter (index into scene->emitters) of cache light `light`, or -1 when the light is
 * a punctual one or out of range. */
static inline int64_t bbc_scene_light_emitter(const bbc_scene *scene, uint32_t light) {
  if (light < scene->point_light_count) return -1;
  uint64_t e = (uint64_t)light - scene->point_light_count;
  return e < scene->emitter_count ? (int64_t)e : -1;
}

/* The model of emitter e (index into scene->emitters) as an area light (kind
 * BBC_LIGHT_AREA) and its radiance (W/sr/m^2 per RGB channel, the material's emission).
 * Returns 0 when e is out of range. */
BBC_API int bbc_scene_area_light(const bbc_scene *scene, uint32_t e, bbc_light_model *model,
                                 float radiance[3]);

/* The material of a triangle. */
static inline const bbc_material *bbc_scene_triangle_material(const bbc_scene *scene,
                                                              uint32_t triangle) {
  return &scene->materials[scene->meshes[scene->triangle_mesh[triangle]].material];
}

#ifdef __cplusplus
}
#endif

#endif
