/* glTF written the way Blender's exporter (3.4, default settings) writes it, for the
 * loader tests: lights in candela with no light_units flag, cameras with aspectRatio
 * and no image size, bbc settings as camera-data extras, and a data-URI buffer.
 *
 * The scene is a floor quad (y = 0, [-1,1]^2, normal +y, TEXCOORD_0) and a caster: a
 * closed octahedron of radius 0.5 centred at (0, 1, 0) (8 triangles, shared vertices,
 * vertex normals pointing out), or its upper half (4 triangles, an open mesh). The
 * caller gives the JSON of everything else. */
#ifndef BBC_TEST_BLENDER_STYLE_H
#define BBC_TEST_BLENDER_STYLE_H

#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "json_text.h"

typedef struct blender_style {
  const char *asset_extras; /* e.g. {"bbc":{"light_units":"radiometric"}}; NULL for none */
  const char *lights;       /* the KHR_lights_punctual lights array; NULL: none */
  const char *materials;    /* materials array: 0 is the floor's, 1 the caster's */
  const char *cameras;      /* cameras array; NULL: none */
  const char *camera_node_extras; /* extras of the camera node; NULL for none */
  int caster;                     /* 0: none, 1: closed octahedron, 2: its open upper half */
  /* Animation: floats appended to the buffer as bufferView 7, accessors 7, 8, ...
   * (anim_accessors, JSON objects without the brackets, offsets relative to the view),
   * and the animations array. rig != 0 makes the camera node (3) a child of node 4,
   * "Rig", at the origin. */
  const float *anim_data;
  size_t anim_floats;
  const char *anim_accessors;
  const char *animations;
  int rig;
  const char *more_cameras; /* further nodes after the camera's, e.g. {"camera":1,...} */
  /* A re-export: 0 writes the octahedron as above; k > 0 permutes its vertices and
   * triangles and rotates each triangle's corners (keeping the winding), as Blender's
   * exporter does from one export to the next, differently for each k. */
  unsigned shuffle;
  /* > 0: moves vertex 2 (the top) up by this much, a real change. */
  float moved;
  /* > 0: adds float noise of up to this much to every caster coordinate and normal
   * component, different for each value of shuffle, as a re-export that recomputes
   * them does (Blender's normals moved by up to 1.8e-7). The x coordinates of four
   * vertices are 0 exactly, so noise reorders them in the loader's canonical order. */
  float noise;
  /* Further top-level members, e.g. "images":[...],"textures":[...]; NULL for none. */
  const char *more_json;
} blender_style;

/* The JSON text of the scene (malloc'd, NUL-terminated). */
static char *blender_style_write(const blender_style *b) {
  /* Buffer: floor positions, normals, uvs, indices; then the caster's. */
  static const float floor_p[4][3] = {{-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1}};
  static const float floor_uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  static const uint16_t floor_i[6] = {0, 2, 1, 0, 3, 2};
  static const float oct[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  /* Counter-clockwise seen from outside: upper four, then lower four. */
  static const uint16_t oct_i[24] = {0, 2, 4, 4, 2, 1, 1, 2, 5, 5, 2, 0,
                                     0, 4, 3, 4, 1, 3, 1, 5, 3, 5, 0, 3};
  unsigned char buf[8192];
  size_t at = 0;
  size_t floor_at[4], caster_at[3];
#define BS_PUT(ptr, bytes) (memcpy(buf + at, ptr, bytes), at += (bytes))
  floor_at[0] = at, BS_PUT(floor_p, sizeof floor_p);
  float floor_n[4][3] = {{0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}};
  floor_at[1] = at, BS_PUT(floor_n, sizeof floor_n);
  floor_at[2] = at, BS_PUT(floor_uv, sizeof floor_uv);
  floor_at[3] = at, BS_PUT(floor_i, sizeof floor_i);
  at = (at + 3) & ~(size_t)3;
  float cp[6][3], cn[6][3];
  uint16_t ci[24];
  /* vertex v of the file is octahedron vertex perm[v]; file triangle t is octahedron
   * triangle (t * step) % 8, its corners rotated by rot. */
  int perm[6] = {0, 1, 2, 3, 4, 5}, inverse[6];
  for (unsigned k = 0; k < b->shuffle; k++)
    for (int v = 5; v > 0; v--) {
      int j = (int)((k * 7 + (unsigned)v * 3 + 1) % (unsigned)(v + 1)), x = perm[v];
      perm[v] = perm[j], perm[j] = x;
    }
  for (int v = 0; v < 6; v++) inverse[perm[v]] = v;
  int ntri = b->caster == 2 ? 4 : 8;
  for (int v = 0; v < 6; v++)
    for (int c = 0; c < 3; c++) {
      int o = perm[v];
      uint32_t h = (uint32_t)(o * 3 + c + 1) * 2654435761u ^ (b->shuffle + 1) * 40503u;
      h ^= h >> 15;
      h *= 2246822519u;
      h ^= h >> 13;
      float e = b->noise * ((float)(h % 2001u) / 1000.0f - 1.0f);
      cp[v][c] = 0.5f * oct[o][c] + (c == 1 ? 1.0f : 0.0f) + (o == 2 && c == 1 ? b->moved : 0.0f) + e;
      cn[v][c] = oct[o][c] + e;
    }
  for (int t = 0; t < ntri; t++) {
    int src = b->shuffle ? (int)((t * 3 + b->shuffle) % (unsigned)ntri) : t;
    int rot = b->shuffle ? (int)((t + b->shuffle) % 3) : 0;
    for (int k = 0; k < 3; k++) ci[3 * t + k] = (uint16_t)inverse[oct_i[3 * src + (k + rot) % 3]];
  }
  caster_at[0] = at, BS_PUT(cp, sizeof cp);
  caster_at[1] = at, BS_PUT(cn, sizeof cn);
  caster_at[2] = at, BS_PUT(ci, sizeof ci);
  at = (at + 3) & ~(size_t)3;
  size_t anim_at = at;
  if (b->anim_floats) BS_PUT(b->anim_data, b->anim_floats * sizeof(float));
#undef BS_PUT
  int caster_triangles = ntri;

  json_text t = {0};
  json_printf(&t,
              "{\"asset\":{\"generator\":\"Khronos glTF Blender I/O v3.4.50\",\"version\":\"2.0\"");
  if (b->asset_extras) json_printf(&t, ",\"extras\":%s", b->asset_extras);
  json_printf(&t, "},\"extensionsUsed\":[\"KHR_lights_punctual\",\"KHR_materials_transmission\"],");
  if (b->lights)
    json_printf(&t, "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":%s}},", b->lights);
  json_printf(&t,
              "\"scene\":0,\"scenes\":[{\"name\":\"Scene\",\"nodes\":[0,1,2,%d%s]}],\"nodes\":[",
              b->rig ? 4 : 3, b->more_cameras ? ",5" : "");
  json_printf(&t, "{\"name\":\"Plane\",\"mesh\":0},");
  if (b->caster)
    json_printf(&t, "{\"name\":\"Ico\",\"mesh\":1},");
  else
    json_printf(&t, "{\"name\":\"Empty\"},");
  if (b->lights)
    json_printf(&t,
                "{\"name\":\"Light\",\"translation\":[0,3,0],"
                "\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}},");
  else
    json_printf(&t, "{\"name\":\"NoLight\"},");
  json_printf(&t, "{\"name\":\"Camera\",\"translation\":[0,1,4]%s%s%s},",
              b->cameras ? ",\"camera\":0" : "", b->camera_node_extras ? ",\"extras\":" : "",
              b->camera_node_extras ? b->camera_node_extras : "");
  json_printf(&t, "{\"name\":\"Rig\"%s}", b->rig ? ",\"children\":[3]" : "");
  if (b->more_cameras) json_printf(&t, ",%s", b->more_cameras);
  json_printf(&t, "]");
  if (b->animations) json_printf(&t, ",\"animations\":%s", b->animations);
  if (b->cameras) json_printf(&t, ",\"cameras\":%s", b->cameras);
  if (b->more_json) json_printf(&t, ",%s", b->more_json);
  json_printf(&t, ",\"materials\":%s",
              b->materials ? b->materials
                           : "[{\"name\":\"Floor\",\"pbrMetallicRoughness\":"
                             "{\"metallicFactor\":0,\"roughnessFactor\":1}}]");
  json_printf(&t,
              ",\"meshes\":[{\"name\":\"Plane\",\"primitives\":[{\"attributes\":{\"POSITION\":0,"
              "\"NORMAL\":1,\"TEXCOORD_0\":2},\"indices\":3,\"material\":0}]}");
  if (b->caster)
    json_printf(&t,
                ",{\"name\":\"Ico\",\"primitives\":[{\"attributes\":{\"POSITION\":4,\"NORMAL\":5},"
                "\"indices\":6,\"material\":1}]}");
  json_printf(&t,
              "],\"accessors\":["
              "{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\","
              "\"min\":[-1,0,-1],\"max\":[1,0,1]},"
              "{\"bufferView\":1,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"},"
              "{\"bufferView\":2,\"componentType\":5126,\"count\":4,\"type\":\"VEC2\"},"
              "{\"bufferView\":3,\"componentType\":5123,\"count\":6,\"type\":\"SCALAR\"},"
              "{\"bufferView\":4,\"componentType\":5126,\"count\":6,\"type\":\"VEC3\","
              "\"min\":[-0.5,0.5,-0.5],\"max\":[0.5,1.5,0.5]},"
              "{\"bufferView\":5,\"componentType\":5126,\"count\":6,\"type\":\"VEC3\"},"
              "{\"bufferView\":6,\"componentType\":5123,\"count\":%d,\"type\":\"SCALAR\"}%s%s],",
              3 * caster_triangles, b->anim_accessors ? "," : "",
              b->anim_accessors ? b->anim_accessors : "");
  size_t views[7][2] = {{floor_at[0], 48}, {floor_at[1], 48},    {floor_at[2], 32},
                        {floor_at[3], 12}, {caster_at[0], 72},  {caster_at[1], 72},
                        {caster_at[2], 6 * (size_t)caster_triangles}};
  json_printf(&t, "\"bufferViews\":[");
  for (int v = 0; v < 7; v++)
    json_printf(&t, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}", v ? "," : "",
                views[v][0], views[v][1]);
  if (b->anim_floats)
    json_printf(&t, ",{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}", anim_at,
                b->anim_floats * sizeof(float));
  json_printf(
      &t, "],\"buffers\":[{\"byteLength\":%zu,\"uri\":\"data:application/octet-stream;base64,", at);
  json_base64(&t, buf, at);
  json_printf(&t, "\"}]}");
  return t.data;
}

#endif
