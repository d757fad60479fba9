/* bbc-scenegen: the glTF 2.0 writer (JSON and binary buffer, or one GLB), the checker
 * texture as PNG, and the staged output files. */
#define _POSIX_C_SOURCE 200809L

#include <ctype.h>
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "scenegen.h"

/* A growable byte buffer, used both for the JSON text and for the binary buffer. */

typedef struct bytes {
  unsigned char *data;
  size_t len, cap;
} bytes;

static void bytes_reserve(bytes *b, size_t extra) {
  if (b->len + extra <= b->cap) return;
  size_t cap = b->cap ? b->cap : 4096;
  while (cap < b->len + extra) cap *= 2;
  b->data = xrealloc(b->data, cap);
  b->cap = cap;
}

static void bytes_append(bytes *b, const void *src, size_t n) {
  bytes_reserve(b, n);
  memcpy(b->data + b->len, src, n);
  b->len += n;
}

/* Pads with the given byte to a multiple of 4, which glTF requires of every accessor
 * offset and of GLB chunks. */
static void bytes_pad4(bytes *b, unsigned char fill) {
  while (b->len % 4) bytes_append(b, &fill, 1);
}

static void bytes_printf(bytes *b, const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  va_list ap2;
  va_copy(ap2, ap);
  int n = vsnprintf(NULL, 0, fmt, ap);
  va_end(ap);
  if (n < 0) die_oom();
  bytes_reserve(b, (size_t)n + 1);
  vsnprintf((char *)b->data + b->len, (size_t)n + 1, fmt, ap2);
  va_end(ap2);
  b->len += (size_t)n;
}

/* Writes a double as the shortest of %.15g..%.17g that reads back exactly, so the JSON
 * stays readable (10, not 10.000000000000000) and loses nothing. */
static void bytes_double(bytes *b, double x) {
  char s[40];
  for (int prec = 15; prec <= 17; prec++) {
    snprintf(s, sizeof s, "%.*g", prec, x);
    if (strtod(s, NULL) == x) break;
  }
  bytes_printf(b, "%s", s);
}

/* Writes a float as it is stored in the buffer; %.9g reads back to the same float, which
 * matters for accessor min/max (validators compare them with the data exactly). */
static void bytes_float(bytes *b, float x) {
  bytes_printf(b, "%.9g", (double)x);
}

/* The camera rotation as a unit quaternion (x, y, z, w): a glTF camera looks down its
 * local -z with +y up, so the rotation's columns are right, up and back. */
static void look_at(vec3 eye, vec3 target, vec3 up, double q[4]) {
  vec3 w = v_normalize(v_sub(eye, target));
  vec3 u = v_normalize(v_cross(up, w));
  vec3 v = v_cross(w, u);
  double m[3][3] = {{u.x, v.x, w.x}, {u.y, v.y, w.y}, {u.z, v.z, w.z}};
  double tr = m[0][0] + m[1][1] + m[2][2];
  if (tr > 0) {
    double r = 2 * sqrt(1 + tr);
    q[3] = r / 4, q[0] = (m[2][1] - m[1][2]) / r, q[1] = (m[0][2] - m[2][0]) / r;
    q[2] = (m[1][0] - m[0][1]) / r;
  } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
    double r = 2 * sqrt(1 + m[0][0] - m[1][1] - m[2][2]);
    q[3] = (m[2][1] - m[1][2]) / r, q[0] = r / 4, q[1] = (m[0][1] + m[1][0]) / r;
    q[2] = (m[0][2] + m[2][0]) / r;
  } else if (m[1][1] > m[2][2]) {
    double r = 2 * sqrt(1 + m[1][1] - m[0][0] - m[2][2]);
    q[3] = (m[0][2] - m[2][0]) / r, q[0] = (m[0][1] + m[1][0]) / r, q[1] = r / 4;
    q[2] = (m[1][2] + m[2][1]) / r;
  } else {
    double r = 2 * sqrt(1 + m[2][2] - m[0][0] - m[1][1]);
    q[3] = (m[1][0] - m[0][1]) / r, q[0] = (m[0][2] + m[2][0]) / r;
    q[1] = (m[1][2] + m[2][1]) / r, q[2] = r / 4;
  }
  /* q and -q are the same rotation; a non-negative w makes the output unique. */
  double sign = q[3] < 0 ? -1 : 1,
         len = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  for (int i = 0; i < 4; i++) q[i] *= sign / len;
  /* Rounding can leave tiny values of either sign where the rotation has exact zeros;
   * flushing them keeps the JSON clean and the same on every machine. */
  for (int i = 0; i < 4; i++)
    if (fabs(q[i]) < 1e-15) q[i] = 0;
}

/* ------------------------------------------------------------------------------------ */
/* The checker texture: an N x N PNG, written uncompressed (zlib "stored" blocks), so the
 * generator needs no compression library. */

/* The checker's two sRGB colours: light sand and a tile blue. */
static const unsigned char CHECKER_LIGHT[3] = {235, 222, 190};
static const unsigned char CHECKER_DARK[3] = {40, 96, 160};

static uint32_t crc32_update(uint32_t crc, const unsigned char *p, size_t n) {
  crc = ~crc;
  for (size_t i = 0; i < n; i++) {
    crc ^= p[i];
    for (int k = 0; k < 8; k++) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

static void put_be32(bytes *b, uint32_t x) {
  unsigned char c[4] = {(unsigned char)(x >> 24), (unsigned char)(x >> 16), (unsigned char)(x >> 8),
                        (unsigned char)x};
  bytes_append(b, c, 4);
}

static void png_chunk(bytes *png, const char *type, const unsigned char *data, size_t n) {
  put_be32(png, (uint32_t)n);
  size_t start = png->len;
  bytes_append(png, type, 4);
  if (n) bytes_append(png, data, n);
  put_be32(png, crc32_update(0, png->data + start, n + 4));
}

/* Texel (i, j) (column, row from the top) is light where i + j is even. */
static void checker_png(unsigned long n, bytes *png) {
  bytes raw = {0}, z = {0};
  for (unsigned long j = 0; j < n; j++) {
    unsigned char filter = 0;
    bytes_append(&raw, &filter, 1);
    for (unsigned long i = 0; i < n; i++)
      bytes_append(&raw, (i + j) % 2 == 0 ? CHECKER_LIGHT : CHECKER_DARK, 3);
  }
  static const unsigned char zlib_header[2] = {0x78, 0x01};
  bytes_append(&z, zlib_header, 2);
  for (size_t off = 0; off < raw.len || off == 0; off += 65535) {
    size_t len = raw.len - off < 65535 ? raw.len - off : 65535;
    unsigned char h[5] = {(unsigned char)(off + len == raw.len), (unsigned char)len,
                          (unsigned char)(len >> 8), (unsigned char)~len,
                          (unsigned char)(~len >> 8)};
    bytes_append(&z, h, 5);
    bytes_append(&z, raw.data + off, len);
    if (off + len == raw.len) break;
  }
  uint32_t a = 1, b2 = 0;
  for (size_t i = 0; i < raw.len; i++) {
    a = (a + raw.data[i]) % 65521u;
    b2 = (b2 + a) % 65521u;
  }
  put_be32(&z, b2 << 16 | a);
  static const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  bytes_append(png, signature, 8);
  unsigned char ihdr[13] = {(unsigned char)(n >> 24),
                            (unsigned char)(n >> 16),
                            (unsigned char)(n >> 8),
                            (unsigned char)n,
                            (unsigned char)(n >> 24),
                            (unsigned char)(n >> 16),
                            (unsigned char)(n >> 8),
                            (unsigned char)n,
                            8,
                            2,
                            0,
                            0,
                            0}; /* 8-bit RGB, no interlace */
  png_chunk(png, "IHDR", ihdr, 13);
  png_chunk(png, "IDAT", z.data, z.len);
  png_chunk(png, "IEND", NULL, 0);
  free(raw.data);
  free(z.data);
}

/* ------------------------------------------------------------------------------------ */
/* glTF output. */

static const char *const MATERIAL_NAMES[MAT_COUNT] = {"diffuse", "mirror",  "glass", "water",
                                                      "diamond", "emitter", "deck"};

static void json_material(bytes *j, const scene *s, material_kind k) {
  bytes_printf(j, "{\"name\":\"%s\",\"pbrMetallicRoughness\":", MATERIAL_NAMES[k]);
  switch (k) {
    case MAT_DIFFUSE:
      /* With --checker the texture gives the colour (factor 1); --roughness and
       * --metallic make the receiver glossy. */
      bytes_printf(j, "{\"baseColorFactor\":%s,\"metallicFactor\":",
                   s->opts->checker ? "[1,1,1,1]" : "[0.8,0.8,0.8,1]");
      bytes_double(j, s->opts->metallic);
      bytes_printf(j, ",\"roughnessFactor\":");
      bytes_double(j, s->opts->roughness);
      if (s->opts->checker) bytes_printf(j, ",\"baseColorTexture\":{\"index\":0}");
      bytes_printf(j, "}}");
      break;
    case MAT_MIRROR:
      bytes_printf(j,
                   "{\"baseColorFactor\":[1,1,1,1],\"metallicFactor\":1,"
                   "\"roughnessFactor\":0}}");
      break;
    case MAT_GLASS:
    case MAT_WATER:
    case MAT_DIAMOND:
      bytes_printf(j,
                   "{\"baseColorFactor\":[1,1,1,1],\"metallicFactor\":0,"
                   "\"roughnessFactor\":0},\"extensions\":{"
                   "\"KHR_materials_transmission\":{\"transmissionFactor\":1},"
                   "\"KHR_materials_volume\":{\"thicknessFactor\":1},"
                   "\"KHR_materials_ior\":{\"ior\":%s}}}",
                   k == MAT_GLASS   ? "1.5"
                   : k == MAT_WATER ? "1.33"
                                    : "2.42");
      break;
    case MAT_DECK:
      /* glass-pool's deck: light warm stone, matte. */
      bytes_printf(j,
                   "{\"baseColorFactor\":[0.75,0.72,0.66,1],\"metallicFactor\":0,"
                   "\"roughnessFactor\":1}}");
      break;
    default:
      /* A black base colour: the lamp only emits, it reflects nothing. */
      bytes_printf(j,
                   "{\"baseColorFactor\":[0,0,0,1],\"metallicFactor\":0,"
                   "\"roughnessFactor\":1},\"emissiveFactor\":[1,1,1],\"extensions\":{"
                   "\"KHR_materials_emissive_strength\":{\"emissiveStrength\":");
      bytes_double(j, emissive_strength(s));
      bytes_printf(j, "}}}");
      break;
  }
}

static const char *const ROLE_NAMES[] = {"caster", "receiver", "none"};

/* Appends one attribute to the binary buffer and writes its bufferView and accessor;
 * returns the accessor's index. */
typedef struct gltf_writer {
  bytes bin, views, accessors;
  uint32_t view_count, accessor_count;
} gltf_writer;

static uint32_t write_accessor(gltf_writer *g, const void *data, size_t elem_size, uint32_t count,
                               int component, const char *type, int target, const float *min,
                               const float *max, int comps) {
  size_t offset = g->bin.len, length = elem_size * count;
  bytes_append(&g->bin, data, length);
  bytes_pad4(&g->bin, 0);
  bytes_printf(&g->views, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu",
               g->view_count ? "," : "", offset, length);
  if (target) bytes_printf(&g->views, ",\"target\":%d", target); /* none for animation data */
  bytes_printf(&g->views, "}");
  bytes_printf(&g->accessors,
               "%s{\"bufferView\":%u,\"componentType\":%d,\"count\":%u,"
               "\"type\":\"%s\"",
               g->accessor_count ? "," : "", g->view_count, component, count, type);
  if (min) {
    bytes_printf(&g->accessors, ",\"min\":[");
    for (int i = 0; i < comps; i++) {
      if (i) bytes_printf(&g->accessors, ",");
      bytes_float(&g->accessors, min[i]);
    }
    bytes_printf(&g->accessors, "],\"max\":[");
    for (int i = 0; i < comps; i++) {
      if (i) bytes_printf(&g->accessors, ",");
      bytes_float(&g->accessors, max[i]);
    }
    bytes_printf(&g->accessors, "]");
  }
  bytes_printf(&g->accessors, "}");
  g->view_count++;
  return g->accessor_count++;
}

enum {
  GLTF_UNSIGNED_SHORT = 5123,
  GLTF_UNSIGNED_INT = 5125,
  GLTF_FLOAT = 5126,
  GLTF_ARRAY_BUFFER = 34962,
  GLTF_ELEMENT_ARRAY_BUFFER = 34963
};

/* Writes a mesh's attributes and indices; returns the JSON of its primitive. glTF
 * forbids the largest value of the index type as an index (it means primitive restart
 * to some APIs), so 16-bit indices serve up to 65535 vertices, i.e. indices 0..65534. */
static void write_mesh(gltf_writer *g, const mesh *m, int material_index, bytes *meshes_json,
                       int first) {
  float min[3] = {INFINITY, INFINITY, INFINITY}, max[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (uint32_t v = 0; v < m->vertex_count; v++) {
    for (int c = 0; c < 3; c++) {
      float x = m->positions[3 * v + c];
      if (x < min[c]) min[c] = x;
      if (x > max[c]) max[c] = x;
    }
  }
  uint32_t pos = write_accessor(g, m->positions, 12, m->vertex_count, GLTF_FLOAT, "VEC3",
                                GLTF_ARRAY_BUFFER, min, max, 3);
  uint32_t nrm = write_accessor(g, m->normals, 12, m->vertex_count, GLTF_FLOAT, "VEC3",
                                GLTF_ARRAY_BUFFER, NULL, NULL, 3);
  uint32_t uv = 0;
  if (m->has_uv) {
    uv = write_accessor(g, m->uvs, 8, m->vertex_count, GLTF_FLOAT, "VEC2", GLTF_ARRAY_BUFFER, NULL,
                        NULL, 2);
  }
  uint32_t index_count = 3 * m->triangle_count, idx;
  if (m->vertex_count > 65535) {
    idx = write_accessor(g, m->indices, 4, index_count, GLTF_UNSIGNED_INT, "SCALAR",
                         GLTF_ELEMENT_ARRAY_BUFFER, NULL, NULL, 1);
  } else {
    uint16_t *small = xrealloc(NULL, sizeof(uint16_t) * index_count);
    for (uint32_t i = 0; i < index_count; i++) small[i] = (uint16_t)m->indices[i];
    idx = write_accessor(g, small, 2, index_count, GLTF_UNSIGNED_SHORT, "SCALAR",
                         GLTF_ELEMENT_ARRAY_BUFFER, NULL, NULL, 1);
    free(small);
  }
  bytes_printf(meshes_json,
               "%s{\"name\":\"%s\",\"primitives\":[{\"attributes\":{"
               "\"POSITION\":%u,\"NORMAL\":%u",
               first ? "" : ",", m->name, pos, nrm);
  if (m->has_uv) bytes_printf(meshes_json, ",\"TEXCOORD_0\":%u", uv);
  bytes_printf(meshes_json, "},\"indices\":%u,\"material\":%d,\"mode\":4}]}", idx, material_index);
}

static void json_vec3(bytes *j, vec3 v) {
  bytes_printf(j, "[");
  bytes_double(j, v.x);
  bytes_printf(j, ",");
  bytes_double(j, v.y);
  bytes_printf(j, ",");
  bytes_double(j, v.z);
  bytes_printf(j, "]");
}

/* Percent-encodes a file name for the buffer's uri (RFC 3986 unreserved characters pass
 * through), which also keeps the JSON string free of anything needing escapes. */
static void json_uri(bytes *j, const char *name) {
  for (const unsigned char *c = (const unsigned char *)name; *c; c++) {
    if (isalnum(*c) || *c == '-' || *c == '.' || *c == '_' || *c == '~')
      bytes_append(j, c, 1);
    else
      bytes_printf(j, "%%%02X", *c);
  }
}

/* Builds the JSON document and the binary buffer. uri is NULL for a GLB, whose buffer
 * lives in the file's own BIN chunk. */
static void build_gltf(const scene *s, const char *uri, bytes *json, bytes *bin) {
  const options *o = s->opts;
  gltf_writer g;
  memset(&g, 0, sizeof g);
  bytes meshes = {0}, materials = {0};

  /* Materials in order of first use, so the list holds only what the scene uses. */
  int material_index[MAT_COUNT];
  int material_count = 0;
  for (int k = 0; k < MAT_COUNT; k++) material_index[k] = -1;
  for (int i = 0; i < s->mesh_count; i++) {
    material_kind k = s->meshes[i].material;
    if (material_index[k] >= 0) continue;
    if (material_count) bytes_printf(&materials, ",");
    json_material(&materials, s, k);
    material_index[k] = material_count++;
  }
  for (int i = 0; i < s->mesh_count; i++) {
    write_mesh(&g, &s->meshes[i], material_index[s->meshes[i].material], &meshes, i == 0);
  }
  int point_light = o->area_side <= 0;
  /* --sun and --spot turn the point light into a directional light or a spot aimed from
   * the light's position at the origin (the node's -Z, as KHR_lights_punctual says). */
  const char *light_type = o->sun > 0 ? "directional" : o->spot > 0 ? "spot" : "point";
  int transmissive = material_index[MAT_GLASS] >= 0 || material_index[MAT_WATER] >= 0 ||
                     material_index[MAT_DIAMOND] >= 0;

  bytes_printf(json, "{\"asset\":{\"version\":\"2.0\",\"generator\":\"" TOOL
                     "\",\"extras\":{\"bbc\":{\"light_units\":\"radiometric\"}}}");
  if (point_light || transmissive || material_index[MAT_EMITTER] >= 0) {
    const char *sep = "";
    bytes_printf(json, ",\"extensionsUsed\":[");
    if (point_light) bytes_printf(json, "%s\"KHR_lights_punctual\"", sep), sep = ",";
    if (transmissive) {
      bytes_printf(json,
                   "%s\"KHR_materials_transmission\",\"KHR_materials_volume\","
                   "\"KHR_materials_ior\"",
                   sep);
      sep = ",";
    }
    if (material_index[MAT_EMITTER] >= 0)
      bytes_printf(json, "%s\"KHR_materials_emissive_strength\"", sep);
    bytes_printf(json, "]");
  }
  if (point_light) {
    bytes_printf(json,
                 ",\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"name\":"
                 "\"light\",\"type\":\"%s\",\"color\":",
                 light_type);
    json_vec3(json, v3(s->color[0], s->color[1], s->color[2]));
    bytes_printf(json, ",\"intensity\":");
    bytes_double(json, o->sun > 0 ? o->sun : s->intensity);
    if (o->spot > 0) {
      bytes_printf(json, ",\"spot\":{\"innerConeAngle\":");
      bytes_double(json, o->spot / 2);
      bytes_printf(json, ",\"outerConeAngle\":");
      bytes_double(json, o->spot);
      bytes_printf(json, "}");
    }
    if (o->sun > 0 && o->sun_angle > 0) {
      bytes_printf(json, ",\"extras\":{\"bbc\":{\"angular_diameter\":");
      bytes_double(json, o->sun_angle);
      bytes_printf(json, "}}");
    }
    bytes_printf(json, "}]}}");
  }

  /* Nodes: one per mesh, then the point light, then the camera (and, with --orbit, the
   * side camera). */
  int orbit = o->orbit > 0;
  int node_count = s->mesh_count + point_light + 1 + orbit;
  bytes_printf(json, ",\"scene\":0,\"scenes\":[{\"name\":\"%s\",\"nodes\":[", KINDS[o->kind].name);
  for (int i = 0; i < node_count; i++) bytes_printf(json, "%s%d", i ? "," : "", i);
  bytes_printf(json, "],\"extras\":{\"bbc\":{\"kind\":\"%s\",\"triangles\":%u}}}]",
               KINDS[o->kind].name, s->caster_triangles);
  bytes_printf(json, ",\"nodes\":[");
  for (int i = 0; i < s->mesh_count; i++) {
    bytes_printf(json, "%s{\"name\":\"%s\",\"mesh\":%d,\"extras\":{\"bbc\":{\"role\":\"%s\"}}}",
                 i ? "," : "", s->meshes[i].name, i, ROLE_NAMES[s->meshes[i].role]);
  }
  if (point_light) {
    bytes_printf(json, ",{\"name\":\"light\",\"translation\":");
    json_vec3(json, s->light);
    if (o->sun > 0 || o->spot > 0) {
      vec3 d = v_normalize(v_sub(v3(0, 0, 0), s->light));
      double lq[4];
      look_at(s->light, v3(0, 0, 0), fabs(d.y) > 0.99 ? v3(0, 0, 1) : v3(0, 1, 0), lq);
      bytes_printf(json, ",\"rotation\":[");
      for (int i = 0; i < 4; i++) {
        if (i) bytes_printf(json, ",");
        bytes_double(json, lq[i]);
      }
      bytes_printf(json, "]");
    }
    bytes_printf(json, ",\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}");
  }
  double q[4];
  look_at(s->eye, s->target, s->up, q);
  bytes_printf(json, ",{\"name\":\"camera\",\"camera\":0,\"translation\":");
  json_vec3(json, s->eye);
  bytes_printf(json, ",\"rotation\":[");
  for (int i = 0; i < 4; i++) {
    if (i) bytes_printf(json, ",");
    bytes_double(json, q[i]);
  }
  bytes_printf(json, "],\"extras\":{\"bbc\":{\"width\":%lu,\"height\":%lu}}}", o->width, o->height);
  /* --orbit: the camera node turns about its target by 20 degrees over o->orbit keys,
   * one per frame at 24 frames per second (LINEAR), about the axis through the target
   * along the image's up direction; a second, static camera looks from the eye turned
   * by 60 degrees. */
  uint32_t orbit_accessors[3] = {0, 0, 0};
  if (orbit) {
    vec3 d = v_sub(s->eye, s->target);
    vec3 axis = v_normalize(v_cross(v_cross(d, s->up), d)); /* up, orthogonal to d */
    vec3 axis_d = v_cross(axis, d);
#define ORBIT_EYE(a) v_add(s->target, v_add(v_scale(d, cos(a)), v_scale(axis_d, sin(a))))
    vec3 side = ORBIT_EYE(PI / 3);
    look_at(side, s->target, axis, q);
    bytes_printf(json, ",{\"name\":\"side\",\"camera\":1,\"translation\":");
    json_vec3(json, side);
    bytes_printf(json, ",\"rotation\":[");
    for (int i = 0; i < 4; i++) {
      if (i) bytes_printf(json, ",");
      bytes_double(json, q[i]);
    }
    bytes_printf(json, "]}");
    uint32_t keys = (uint32_t)o->orbit;
    float *times = xrealloc(NULL, sizeof(float) * keys);
    float *eyes = xrealloc(NULL, sizeof(float) * 3 * keys);
    float *rotations = xrealloc(NULL, sizeof(float) * 4 * keys);
    for (uint32_t k = 0; k < keys; k++) {
      double a = (20.0 * PI / 180.0) * k / (keys - 1);
      vec3 eye = ORBIT_EYE(a);
      double qk[4];
      look_at(eye, s->target, axis, qk);
      times[k] = (float)(k / 24.0);
      eyes[3 * k] = (float)eye.x, eyes[3 * k + 1] = (float)eye.y, eyes[3 * k + 2] = (float)eye.z;
      for (int i = 0; i < 4; i++) rotations[4 * k + i] = (float)qk[i];
    }
    float t0 = times[0], t1 = times[keys - 1];
    orbit_accessors[0] = write_accessor(&g, times, 4, keys, GLTF_FLOAT, "SCALAR", 0, &t0, &t1, 1);
    orbit_accessors[1] = write_accessor(&g, eyes, 12, keys, GLTF_FLOAT, "VEC3", 0, NULL, NULL, 3);
    orbit_accessors[2] =
        write_accessor(&g, rotations, 16, keys, GLTF_FLOAT, "VEC4", 0, NULL, NULL, 4);
    free(times);
    free(eyes);
    free(rotations);
#undef ORBIT_EYE
  }
  bytes_printf(json, "]");
  bytes_printf(json,
               ",\"cameras\":[{\"name\":\"camera\",\"type\":\"perspective\","
               "\"perspective\":{\"aspectRatio\":");
  bytes_double(json, (double)o->width / (double)o->height);
  bytes_printf(json, ",\"yfov\":");
  bytes_double(json, s->yfov);
  bytes_printf(json, ",\"znear\":0.01}}");
  if (orbit) {
    bytes_printf(json,
                 ",{\"name\":\"side\",\"type\":\"perspective\",\"perspective\":{"
                 "\"aspectRatio\":");
    bytes_double(json, (double)o->width / (double)o->height);
    bytes_printf(json, ",\"yfov\":");
    bytes_double(json, s->yfov);
    bytes_printf(json, ",\"znear\":0.01}}");
  }
  bytes_printf(json, "]");
  if (orbit) {
    int camera_node = s->mesh_count + point_light;
    bytes_printf(json,
                 ",\"animations\":[{\"name\":\"orbit\",\"channels\":["
                 "{\"sampler\":0,\"target\":{\"node\":%d,\"path\":\"translation\"}},"
                 "{\"sampler\":1,\"target\":{\"node\":%d,\"path\":\"rotation\"}}],"
                 "\"samplers\":[{\"input\":%u,\"output\":%u,\"interpolation\":\"LINEAR\"},"
                 "{\"input\":%u,\"output\":%u,\"interpolation\":\"LINEAR\"}]}]",
                 camera_node, camera_node, orbit_accessors[0], orbit_accessors[1],
                 orbit_accessors[0], orbit_accessors[2]);
  }

  bytes_printf(json, ",\"meshes\":[");
  bytes_append(json, meshes.data, meshes.len);
  bytes_printf(json, "],\"materials\":[");
  bytes_append(json, materials.data, materials.len);
  if (o->checker && material_index[MAT_DIFFUSE] >= 0) {
    /* The checker PNG lives in the buffer, in a bufferView of its own. */
    bytes png = {0};
    checker_png(o->checker, &png);
    size_t offset = g.bin.len;
    bytes_append(&g.bin, png.data, png.len);
    bytes_pad4(&g.bin, 0);
    bytes_printf(&g.views, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}",
                 g.view_count ? "," : "", offset, png.len);
    bytes_printf(json,
                 "],\"images\":[{\"name\":\"checker\",\"bufferView\":%u,"
                 "\"mimeType\":\"image/png\"}],\"samplers\":[{\"magFilter\":9728,"
                 "\"minFilter\":9728,\"wrapS\":10497,\"wrapT\":10497}],"
                 "\"textures\":[{\"source\":0,\"sampler\":0}",
                 g.view_count++);
    free(png.data);
  }
  bytes_printf(json, "],\"accessors\":[");
  bytes_append(json, g.accessors.data, g.accessors.len);
  bytes_printf(json, "],\"bufferViews\":[");
  bytes_append(json, g.views.data, g.views.len);
  bytes_printf(json, "],\"buffers\":[{");
  if (uri) {
    bytes_printf(json, "\"uri\":\"");
    json_uri(json, uri);
    bytes_printf(json, "\",");
  }
  bytes_printf(json, "\"byteLength\":%zu}]}\n", g.bin.len);

  *bin = g.bin;
  free(g.views.data);
  free(g.accessors.data);
  free(meshes.data);
  free(materials.data);
}

/* Packs JSON and buffer into a GLB: a 12-byte header, a JSON chunk padded with spaces and
 * a BIN chunk padded with zeros, all little-endian. */
static void put_u32(bytes *b, uint32_t x) {
  unsigned char c[4] = {(unsigned char)x, (unsigned char)(x >> 8), (unsigned char)(x >> 16),
                        (unsigned char)(x >> 24)};
  bytes_append(b, c, 4);
}

static void build_glb(bytes *json, const bytes *bin, bytes *glb) {
  bytes_pad4(json, ' ');
  size_t bin_len = (bin->len + 3) & ~(size_t)3;
  put_u32(glb, 0x46546C67u); /* "glTF" */
  put_u32(glb, 2);
  put_u32(glb, (uint32_t)(12 + 8 + json->len + 8 + bin_len));
  put_u32(glb, (uint32_t)json->len);
  put_u32(glb, 0x4E4F534Au); /* "JSON" */
  bytes_append(glb, json->data, json->len);
  put_u32(glb, (uint32_t)bin_len);
  put_u32(glb, 0x004E4942u); /* "BIN\0" */
  bytes_append(glb, bin->data, bin->len);
  bytes_pad4(glb, 0);
}

/* Outputs are written to a temporary beside the final name and renamed into place, so a
 * reader never sees a half-written scene and a failed run leaves earlier files intact.
 * The temporary's name carries the process id so that concurrent runs do not collide. */
typedef struct staged_file {
  const char *path; /* the final name */
  char *tmp;        /* the written temporary, or NULL */
} staged_file;

static void report_write_error(const char *path, int err) {
  fprintf(stderr, TOOL ": cannot write %s: %s\n", path, strerror(err));
}

/* Writes data to the temporary of path; on failure says so and returns -1. */
static int stage_file(staged_file *st, const char *path, const void *data, size_t len) {
  size_t n = strlen(path) + 32;
  st->path = path;
  st->tmp = xrealloc(NULL, n);
  snprintf(st->tmp, n, "%s.tmp%ld", path, (long)getpid());
  FILE *f = fopen(st->tmp, "wbx");
  int err = 0;
  if (!f) {
    err = errno;
  } else {
    if (fwrite(data, 1, len, f) != len) err = errno ? errno : EIO;
    if (fclose(f) != 0 && !err) err = errno ? errno : EIO;
    if (err) remove(st->tmp);
  }
  if (err) {
    free(st->tmp);
    st->tmp = NULL;
    report_write_error(path, err);
    return -1;
  }
  return 0;
}

/* Removes a staged temporary that will not be committed; harmless if none was written. */
static void discard_file(staged_file *st) {
  if (st->tmp) remove(st->tmp);
  free(st->tmp);
  st->tmp = NULL;
}

/* Renames the temporary to its final name. */
static int commit_file(staged_file *st) {
  int rc = rename(st->tmp, st->path) == 0 ? 0 : -1;
  if (rc) report_write_error(st->path, errno);
  discard_file(st);
  return rc;
}

/* The buffer of OUT.gltf goes to OUT.bin (any other name gets .bin appended). */
static char *bin_path_for(const char *path) {
  size_t n = strlen(path);
  char *bin = xrealloc(NULL, n + 5);
  memcpy(bin, path, n + 1);
  if (n >= 5 && strcmp(path + n - 5, ".gltf") == 0) bin[n - 5] = '\0';
  strcat(bin, ".bin");
  return bin;
}

int write_scene(const scene *s) {
  const options *o = s->opts;
  bytes json = {0}, bin = {0};
  int rc = 0;
  if (o->glb) {
    bytes glb = {0};
    build_gltf(s, NULL, &json, &bin);
    build_glb(&json, &bin, &glb);
    staged_file out = {0};
    rc = stage_file(&out, o->output, glb.data, glb.len);
    if (rc == 0) rc = commit_file(&out);
    free(glb.data);
  } else {
    char *bin_path = bin_path_for(o->output);
    const char *slash = strrchr(bin_path, '/');
    build_gltf(s, slash ? slash + 1 : bin_path, &json, &bin);
    /* Both files are written in full before either replaces anything, so the usual
     * failures (no such folder, no permission, disk full) leave an earlier pair as it
     * was. The buffer is renamed first: the new .gltf never points at an older .bin. */
    staged_file out_bin = {0}, out_gltf = {0};
    rc = stage_file(&out_bin, bin_path, bin.data, bin.len);
    if (rc == 0) rc = stage_file(&out_gltf, o->output, json.data, json.len);
    if (rc == 0) rc = commit_file(&out_bin);
    if (rc == 0) rc = commit_file(&out_gltf);
    discard_file(&out_bin);
    discard_file(&out_gltf);
    free(bin_path);
  }
  free(json.data);
  free(bin.data);
  return rc;
}
