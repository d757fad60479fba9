/* A C view of a glTF 2.0 file, produced by the library's one C++ file (gltf_shim.cpp),
 * which wraps tinygltf so that no C++ type or exception ever reaches C code.
 *
 * The interface follows cgltf: a zero-initialised options struct means the defaults,
 * the parsed data comes back through an out-parameter, every call that can fail
 * returns a bbc_result and sends one line naming the file and the problem to
 * error_fn, and bbc__gltf_free accepts NULL.
 *
 * The view is already flattened the way bbc wants it: the node tree of the default
 * scene is walked once, each mesh primitive reached is listed with its node's world
 * matrix, and its attributes are copied into tightly packed float arrays and 32-bit
 * indices. Everything is checked against the buffers before it is read, so a consumer
 * may trust every count, index and pointer. What the shim does not judge is whether
 * the content suits bbc (primitive modes, material models, light types, finite
 * positions); that is scene.c's job. */
#ifndef BBC_GLTF_SHIM_INTERNAL_H
#define BBC_GLTF_SHIM_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "bbc/common.h"
#include "bbc/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

/* glTF stores matrices column-major: element (row r, column c) is m[4 * c + r]. */
typedef struct bbc__gltf_primitive {
  double world[16];      /* the node's world matrix (all ancestors applied) */
  const char *node_name; /* never NULL; "" when the node has no name */
  const char *mesh_name; /* never NULL; "" when the mesh has no name */
  uint32_t node_index;   /* indices into the file's arrays, for messages */
  uint32_t mesh_index;
  uint32_t primitive_index; /* within its mesh */
  int mode;                 /* glTF primitive mode as written: 4 means triangles */
  int32_t material;         /* index into bbc__gltf_data.materials, or -1 for none */
  const char *role;         /* the node's extras.bbc.role; NULL when absent, and
                               "<not a string>" when present with another JSON type */
  uint32_t vertex_count;
  const float *positions;  /* 3 floats per vertex; NULL only when vertex_count is 0 */
  const float *normals;    /* 3 floats per vertex, or NULL without NORMAL */
  const float *uvs;        /* 2 floats per vertex, or NULL without TEXCOORD_0 */
  uint32_t index_count;    /* for non-indexed primitives, equal to vertex_count */
  const uint32_t *indices; /* each < vertex_count; 0, 1, 2, ... when non-indexed */
} bbc__gltf_primitive;

/* A material's use of a texture (glTF textureInfo with KHR_texture_transform). */
typedef struct bbc__gltf_texture_ref {
  int32_t texture;  /* index into bbc__gltf_data.textures (checked), or -1 for none */
  int texcoord;     /* the TEXCOORD_n set, after KHR_texture_transform's override */
  double offset[2]; /* KHR_texture_transform, defaults 0, 0 */
  double rotation;  /* default 0 */
  double scale[2];  /* default 1, 1 */
} bbc__gltf_texture_ref;

/* The factors of a glTF material, with the defaults of the specification filled in
 * for anything absent, and its base colour texture. */
typedef struct bbc__gltf_material {
  const char *name;         /* never NULL; "" when unnamed */
  double base_color[4];     /* pbrMetallicRoughness.baseColorFactor, default 1 */
  double metallic;          /* metallicFactor, default 1 */
  double roughness;         /* roughnessFactor, default 1 */
  double transmission;      /* KHR_materials_transmission.transmissionFactor, default 0 */
  double thickness;         /* KHR_materials_volume.thicknessFactor, default 0 */
  double attenuation_color[3]; /* KHR_materials_volume.attenuationColor, default 1 */
  double attenuation_distance; /* KHR_materials_volume.attenuationDistance, default +inf */
  double ior;               /* KHR_materials_ior.ior, default 1.5 */
  double emissive[3];       /* emissiveFactor, default 0 */
  double emissive_strength; /* KHR_materials_emissive_strength, default 1 */
  bbc__gltf_texture_ref base_color_texture; /* pbrMetallicRoughness.baseColorTexture */
  /* pbrMetallicRoughness.metallicRoughnessTexture (roughness in G, metallic in B) and
   * KHR_materials_transmission.transmissionTexture (R); texture -1 when absent. */
  bbc__gltf_texture_ref metallic_roughness_texture, transmission_texture;
  bbc__gltf_texture_ref emissive_texture; /* emissiveTexture (sRGB colour) */
  bbc_alpha_mode alpha_mode; /* alphaMode (checked), default OPAQUE */
  double alpha_cutoff;       /* alphaCutoff (checked: finite, >= 0), default 0.5 */
} bbc__gltf_material;

/* A glTF texture: its image and the wrap modes and magnification filter of its sampler
 * (glTF's enum values; a texture without sampler has REPEAT, REPEAT and filter -1). */
typedef struct bbc__gltf_texture {
  int32_t image; /* index into bbc__gltf_data.images (checked), or -1 for none */
  int wrap_s, wrap_t, mag_filter;
} bbc__gltf_texture;

/* A glTF image, decoded when a material's texture bbc reads uses it (by tinygltf's
 * LoadImageData: PNG, JPEG and the other formats of stb_image), as RGBA with 8 or 16 bits
 * per channel, rows from the top. An image that is not used is not decoded. */
typedef struct bbc__gltf_image {
  const char *name;  /* never NULL: the image's name, else its uri, else "" */
  uint32_t width, height;
  int bits;          /* 8 or 16; 0 when not decoded */
  const void *rgba;  /* width x height x 4 channels, or NULL when not decoded */
  const char *problem; /* NULL when decoded or unused; otherwise why it could not be,
                          e.g. "cannot read textures/wood.png" */
} bbc__gltf_image;

/* A KHR_lights_punctual light placed by a node of the default scene. */
typedef struct bbc__gltf_light {
  const char *name; /* never NULL; the light's name, else the node's, else "" */
  const char *type; /* never NULL: "point", "spot", "directional" or as written */
  uint32_t node_index;
  double position[3]; /* world position of the node's origin */
  double color[3];    /* default 1 */
  double intensity;   /* default 1 */
  double direction[3]; /* the node's world -Z axis (not normalised; spot and directional) */
  double inner_cone, outer_cone; /* spot.innerConeAngle, outerConeAngle (defaults 0, pi/4) */
  /* The light's own extras.bbc.angular_diameter (degrees, as written; suns only): 1 and
   * the number when present as a number, else 0 (a non-number is noted and ignored). */
  int has_angular_diameter;
  double angular_diameter;
} bbc__gltf_light;

/* One animated property of a node (glTF 2.0, section 3.11), checked: key times are
 * finite and strictly increasing, and there are as many values as the interpolation
 * needs. */
typedef struct bbc__gltf_channel {
  int path;          /* 0 translation, 1 rotation (quaternion x, y, z, w), 2 scale */
  int interpolation; /* 0 LINEAR, 1 STEP, 2 CUBICSPLINE */
  uint32_t key_count;
  const float *times;  /* seconds */
  const float *values; /* key_count elements of 3 (4 for rotation) floats; for CUBICSPLINE
                          3 elements per key: in-tangent, value, out-tangent */
} bbc__gltf_channel;

/* A node on the way from a root of the default scene to a camera. */
typedef struct bbc__gltf_node_motion {
  uint32_t node_index;
  int has_matrix; /* its local transform is "matrix" (glTF forbids animating it) */
  double matrix[16];
  double translation[3], rotation[4], scale[3]; /* otherwise its static TRS */
  const bbc__gltf_channel *channels[3];         /* per path; NULL when not animated */
} bbc__gltf_node_motion;

/* A node with a camera; cameras are listed in a depth-first walk of the default scene
 * (roots in order, children in order, a node before its children). */
typedef struct bbc__gltf_camera {
  const char *name; /* never NULL; the camera's name, else the node's, else "" */
  const char *type; /* never NULL: "perspective", "orthographic" or as written */
  uint32_t node_index;
  double world[16];    /* the node's world matrix; the camera looks along -z */
  double yfov;         /* perspective.yfov, radians */
  double aspect_ratio; /* perspective.aspectRatio; 0 when absent */
  /* extras.bbc.width/height of the node, else of the camera (cameras[i].extras, where
   * Blender writes the camera data's custom properties). A value that is not a number
   * leaves has_* at 0 and is listed in bbc__gltf_data.notes. */
  int has_width;
  int has_height;
  double width;
  double height;
  /* The nodes from the root to the camera's (last), with their animation channels. */
  uint32_t path_length;
  const bbc__gltf_node_motion *path;
  int animated; /* some channel of an animation moves a node of the path */
} bbc__gltf_camera;

/* The whole view. Every pointer in it, including those inside the arrays, is owned by
 * the view and stays valid until bbc__gltf_free. It is immutable, so any number of
 * threads may read it at once. */
typedef struct bbc__gltf_data {
  const char *light_units; /* asset.extras.bbc.light_units; NULL when absent, and
                              "<not a string>" when present with another JSON type */
  uint32_t primitive_count;
  bbc__gltf_primitive *primitives; /* in node order, then primitive order */
  uint32_t material_count;
  bbc__gltf_material *materials; /* all materials of the file, in file order */
  uint32_t light_count;
  bbc__gltf_light *lights; /* lights placed by nodes, in node order */
  uint32_t camera_count;
  bbc__gltf_camera *cameras; /* in walk order */
  uint32_t texture_count;
  bbc__gltf_texture *textures; /* all textures of the file, in file order */
  uint32_t image_count;
  bbc__gltf_image *images;     /* all images of the file, in file order */
  uint32_t animation_count;  /* animations in the file, whatever they move */
  /* Extras that look meant for bbc but are not read (a flat "bbc.role" key, extras.bbc
   * that is not an object, an unknown key inside it, a string where a number belongs),
   * one message each, for the loader to warn about. */
  uint32_t note_count;
  const char *const *notes;
  void *internal;          /* storage behind the pointers above */
} bbc__gltf_data;

typedef struct bbc__gltf_options {
  bbc_message_fn error_fn; /* optional: the one-line reason for a failure */
  void *user;              /* passed to error_fn */
} bbc__gltf_options;

/* Parses a .gltf or .glb file; which of the two is decided by the first four bytes
 * ("glTF" means binary), never by the extension. External buffers are looked up
 * beside the file, and so are external images. Only the images of base colour textures
 * are decoded; one that is missing or cannot be decoded is reported in its `problem`
 * (the loader warns and renders without it), so it never stops a scene from loading.
 *
 * Returns BBC_OK and sets *out, or sets *out to NULL and returns BBC_ERR_IO (cannot
 * read the file), BBC_ERR_GLTF (malformed JSON or GLB, missing or short buffer, bad
 * references, data outside its buffer, out-of-range indices, a node hierarchy that
 * is not a tree), BBC_ERR_SCENE (valid glTF using a feature bbc cannot represent:
 * non-float attributes, sparse accessors, an unknown required extension, no scene)
 * or BBC_ERR_OUT_OF_MEMORY, after one call of error_fn whose message starts with the
 * path. out and path must not be NULL (BBC_ERR_INVALID_ARGUMENT); options may be. */
bbc_result bbc__gltf_parse(bbc__gltf_data **out, const char *path,
                           const bbc__gltf_options *options);

/* The same from memory, for tests and fuzzers. name is used in messages only.
 * External buffers (uri that is not a data URI) are looked up in base_dir; when
 * base_dir is NULL they are refused, so parsing never touches the file system. */
bbc_result bbc__gltf_parse_memory(bbc__gltf_data **out, const void *bytes, size_t size,
                                  const char *name, const char *base_dir,
                                  const bbc__gltf_options *options);

/* Releases a view; NULL is allowed. */
void bbc__gltf_free(bbc__gltf_data *data);

/* Loads a scene from memory with the semantics of bbc_scene_load (scene.c), for the
 * fuzzer and tests that must not depend on files. name stands in for the path in
 * messages and in scene->path; base_dir is as for bbc__gltf_parse_memory. */
bbc_result bbc__scene_load_memory(bbc_scene **out, const void *bytes, size_t size, const char *name,
                                  const char *base_dir, const bbc_scene_options *options);

#ifdef __cplusplus
}
#endif

#endif
