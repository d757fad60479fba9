/* Translates a bbc scene (glTF, read by libbbc) into POV-Ray 3.7 SDL with the same
 * camera and radiometry, for the comparison benchmark (bench/compare.sh):
 *
 *   povray_scene SCENE.gltf --width W --height H --direct -o OUT.pov
 *       the receivers lit by the point lights alone (casters left out): the calibration
 *       scene, to match bbc's exact direct image;
 *   povray_scene SCENE.gltf --width W --height H --photons N --radius R -o OUT.pov
 *       the caustic alone, by photon mapping: N photons shot at the casters, gathered
 *       within the fixed radius R; the receivers get no direct light;
 *   ... --any-chain K
 *       the same, with photons also reflected at dielectrics (Fresnel and total internal
 *       reflection) and followed through up to K specular surfaces, as bench/light_trace
 *       --any-chain K counts them (bench/transport.sh).
 *
 * Camera: POV-Ray's perspective camera traces direction + (x/W - 0.5) right +
 * (0.5 - y/H) up for film position (x, y); the vectors are taken from bbc_camera_ray, so
 * film positions map to the same rays as in bbc.
 * Radiometry: POV-Ray's diffuse term is pigment x diffuse x light colour x attenuation x
 * cos. A point light of intensity I (W/sr) becomes colour I / (2 pi D^2) with
 * fade_distance D and fade_power 2, whose attenuation 2 / (1 + (d/D)^2) makes that
 * albedo / pi x I cos / (d^2 + D^2): bbc's radiance to a relative 1e-6 at d >= 1 with
 * D = 1e-3. POV-Ray's photons carry colour x fade(path length) x spread^2 x length^2,
 * the same radiometry. Diffuse: pigment = albedo, diffuse 1, no ambient, no highlights.
 * Mirrors: reflection = reflectance, nothing else. Receivers' triangles are flat (the
 * normals POV-Ray derives from the vertices); mirrors and dielectrics carry the file's
 * vertex normals (mesh2 normal_vectors: POV-Ray interpolates them barycentrically, as bbc
 * does its shading normals).
 * Dielectrics (--photons only): an interior of the material's ior, a pigment that
 * transmits everything, filtered by the base colour (bbc's tint of each refraction,
 * entering or leaving), and Fresnel reflection (reflection { 0, 1 fresnel on }, the exact
 * unpolarised Fresnel reflectance F) with conserve_energy, so that a refracted photon
 * carries (1 - F) x tint per interface: bbc's weight (the light tracer's 1 - F; the
 * estimator's choice of refraction with probability 1 - F). Photons are refracted only
 * (photons { reflection off }): the chains bbc's caches and references count at a
 * dielectric are refractions (T, TT); a Fresnel or total internal reflection ends the
 * photon. Beer-Lambert absorption becomes the interior's exponential fade (fade_power
 * 1001: exp(-(1 - fade_color) d / fade_distance)). In a scene with a dielectric the camera
 * sees the receivers directly only (max_trace_level 1: a camera ray that meets glass or a
 * mirror is black; photons keep their own max_trace_level), as the references count the
 * caustic (bench/light_trace, bbc-render --only caustics --max-depth 2 + chain length).
 * POV-Ray's photon rays skip no_image objects, so the glass cannot simply be hidden from
 * the camera. Nested media follow POV-Ray's rule (the innermost interior entered), not
 * bbc's; so the inner wall of a hollow glass (a cavity, bbc_mesh.cavity) gets an interior
 * of air (ior 1, no absorption): entering it leaves the glass, as in bbc. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"

#define PI 3.14159265358979323846
#define FADE_DISTANCE 1e-3

static int fail(const char *msg) {
  fprintf(stderr, "povray_scene: %s\n", msg);
  return 1;
}

static const char *USAGE =
    "usage: povray_scene SCENE.gltf --width W --height H (--direct | --photons N --radius R "
    "[--any-chain K]) -o OUT.pov";

/* A point of the film plane at distance 1 along the view direction dir0. */
static bbc_vec3 on_film(bbc_vec3 d, bbc_vec3 dir0) {
  double k = d.x * dir0.x + d.y * dir0.y + d.z * dir0.z;
  return (bbc_vec3){d.x / k, d.y / k, d.z / k};
}

/* Writes the opening of a mesh2 and its vertices, its vertex normals when `smooth` and
 * the mesh has them, and its triangles; the caller closes it. */
static void write_mesh(FILE *f, const bbc_scene *s, const bbc_mesh *m, int smooth) {
  fprintf(f, "mesh2 {\n  vertex_vectors { %u", m->vertex_count);
  for (uint32_t v = 0; v < m->vertex_count; v++) {
    const float *p = s->positions + 3 * (size_t)(m->first_vertex + v);
    fprintf(f, ",\n    <%.9g, %.9g, %.9g>", p[0], p[1], p[2]);
  }
  fprintf(f, "\n  }\n");
  if (smooth && m->has_normals) {
    fprintf(f, "  normal_vectors { %u", m->vertex_count);
    for (uint32_t v = 0; v < m->vertex_count; v++) {
      const float *n = s->normals + 3 * (size_t)(m->first_vertex + v);
      fprintf(f, ",\n    <%.9g, %.9g, %.9g>", n[0], n[1], n[2]);
    }
    fprintf(f, "\n  }\n");
  }
  fprintf(f, "  face_indices { %u", m->triangle_count);
  for (uint32_t t = m->first_triangle; t < m->first_triangle + m->triangle_count; t++) {
    const uint32_t *i = s->indices + 3 * (size_t)t;
    fprintf(f, ",\n    <%u, %u, %u>", i[0] - m->first_vertex, i[1] - m->first_vertex,
            i[2] - m->first_vertex);
  }
  fprintf(f, "\n  }\n");
}

int main(int argc, char **argv) {
  const char *scene_path = NULL, *out = NULL;
  long width = 0, height = 0, photons = 0;
  double radius = 0;
  int direct = 0, any_chain = 0;
  for (int i = 1; i < argc; i++) {
    if (!strcmp(argv[i], "--width") && i + 1 < argc) width = atol(argv[++i]);
    else if (!strcmp(argv[i], "--height") && i + 1 < argc) height = atol(argv[++i]);
    else if (!strcmp(argv[i], "--photons") && i + 1 < argc) photons = atol(argv[++i]);
    else if (!strcmp(argv[i], "--radius") && i + 1 < argc) radius = atof(argv[++i]);
    else if (!strcmp(argv[i], "--direct")) direct = 1;
    else if (!strcmp(argv[i], "--any-chain") && i + 1 < argc) any_chain = atoi(argv[++i]);
    else if (!strcmp(argv[i], "-o") && i + 1 < argc) out = argv[++i];
    else if (argv[i][0] != '-' && !scene_path) scene_path = argv[i];
    else return fail(USAGE);
  }
  if (!scene_path || !out || width <= 0 || height <= 0 || width > 100000 || height > 100000 ||
      direct == (photons > 0) || (!direct && !(radius > 0)) || any_chain < 0 || any_chain > 60 ||
      (direct && any_chain))
    return fail(USAGE);
  bbc_scene *scene = NULL;
  if (bbc_scene_load(&scene, scene_path, NULL) != BBC_OK) return fail("cannot load the scene");
  if (scene->emitter_count) return fail("area lights are not translated");
  if (!scene->point_light_count) return fail("the scene has no point light");

  FILE *f = fopen(out, "w");
  if (!f) return fail("cannot write the output");
  fprintf(f, "// %s translated by bench/povray_scene (%s)\n#version 3.7;\n", scene->path,
          direct ? "direct light, no casters" : "caustic by photon mapping");
  int glass = 0;
  for (uint32_t m = 0; m < scene->mesh_count; m++)
    glass |= scene->materials[scene->meshes[m].material].type == BBC_MATERIAL_DIELECTRIC;
  fprintf(f, "global_settings {\n  assumed_gamma 1.0\n  ambient_light rgb 0\n"
             "  max_trace_level %d\n  adc_bailout 0\n", !direct && glass ? 1 : 10);
  if (!direct)
    /* A fixed gather radius: gather at most 10^6 photons (never reached), never fewer
     * than 0, so the radius is never shrunk nor expanded. */
    fprintf(f, "  photons {\n    count %ld\n    radius %.9g, 1\n    gather 0, 1000000\n"
               "    expand_thresholds 0, 0\n    autostop 0\n    max_trace_level %d\n"
               "    adc_bailout 0\n  }\n", photons, radius, any_chain ? any_chain : 10);
  fprintf(f, "}\n");

  /* The camera: rays through the film centre and the middles of its right and top edges
   * give direction, right and up. */
  const uint32_t w = (uint32_t)width, h = (uint32_t)height;
  bbc_vec3 o, d0, dr, du;
  bbc_camera_ray(&scene->camera, w, h, 0.5 * w, 0.5 * h, &o, &d0);
  bbc_camera_ray(&scene->camera, w, h, w, 0.5 * h, &o, &dr);
  bbc_camera_ray(&scene->camera, w, h, 0.5 * w, 0, &o, &du);
  bbc_vec3 pr = on_film(dr, d0), pu = on_film(du, d0);
  fprintf(f, "camera {\n  perspective\n  location <%.17g, %.17g, %.17g>\n"
             "  direction <%.17g, %.17g, %.17g>\n  right <%.17g, %.17g, %.17g>\n"
             "  up <%.17g, %.17g, %.17g>\n}\n",
          o.x, o.y, o.z, d0.x, d0.y, d0.z, 2 * (pr.x - d0.x), 2 * (pr.y - d0.y), 2 * (pr.z - d0.z),
          2 * (pu.x - d0.x), 2 * (pu.y - d0.y), 2 * (pu.z - d0.z));
  fprintf(f, "background { rgb 0 }\n");

  for (uint32_t l = 0; l < scene->point_light_count; l++) {
    const bbc_point_light *pl = &scene->point_lights[l];
    double k = 1 / (2 * PI * FADE_DISTANCE * FADE_DISTANCE);
    fprintf(f, "light_source {\n  <%.17g, %.17g, %.17g>\n  color rgb <%.17g, %.17g, %.17g>\n"
               "  fade_distance %g\n  fade_power 2\n}\n",
            pl->position.x, pl->position.y, pl->position.z, pl->intensity[0] * k,
            pl->intensity[1] * k, pl->intensity[2] * k, FADE_DISTANCE);
  }

  /* The caustic alone: the receivers form a light group without lights, so no light
   * source lights them directly; photons still land on them and are gathered there. */
  if (!direct) fprintf(f, "light_group {\n");
  for (uint32_t m = 0; m < scene->mesh_count; m++) {
    const bbc_mesh *mesh = &scene->meshes[m];
    const bbc_material *mat = &scene->materials[mesh->material];
    if (mat->type != BBC_MATERIAL_DIFFUSE || !mesh->triangle_count) continue;
    if (!direct) fprintf(f, "object {\n"); /* a light group holds objects */
    write_mesh(f, scene, mesh, 0);
    fprintf(f, "  texture {\n    pigment { rgb <%.9g, %.9g, %.9g> }\n"
               "    finish { ambient 0 emission 0 diffuse 1 brilliance 1 specular 0 phong 0 }\n"
               "  }\n", mat->base_color[0], mat->base_color[1], mat->base_color[2]);
    fprintf(f, "}\n");
    if (!direct) fprintf(f, "  photons { collect on }\n}\n");
  }
  if (!direct) fprintf(f, "  global_lights off\n}\n");
  if (!direct) {
    for (uint32_t m = 0; m < scene->mesh_count; m++) {
      const bbc_mesh *mesh = &scene->meshes[m];
      const bbc_material *mat = &scene->materials[mesh->material];
      if (mat->type != BBC_MATERIAL_MIRROR || !mesh->triangle_count) continue;
      write_mesh(f, scene, mesh, 1);
      fprintf(f, "  texture {\n    pigment { rgb 0 }\n"
                 "    finish { ambient 0 emission 0 diffuse 0 specular 0 phong 0\n"
                 "             reflection { rgb <%.9g, %.9g, %.9g> } }\n  }\n"
                 "  photons { target reflection on refraction off collect off }\n}\n",
              mat->base_color[0], mat->base_color[1], mat->base_color[2]);
    }
    for (uint32_t m = 0; m < scene->mesh_count; m++) {
      const bbc_mesh *mesh = &scene->meshes[m];
      const bbc_material *mat = &scene->materials[mesh->material];
      if (mat->type != BBC_MATERIAL_DIELECTRIC || !mesh->triangle_count) continue;
      double tint[3];
      for (int k = 0; k < 3; k++) tint[k] = mat->base_color[k] < 1 ? mat->base_color[k] : 1;
      write_mesh(f, scene, mesh, 1);
      fprintf(f, "  texture {\n    pigment { rgbf <%.9g, %.9g, %.9g, 1> }\n"
                 "    finish { ambient 0 emission 0 diffuse 0 specular 0 phong 0\n"
                 "             reflection { 0, 1 fresnel on } conserve_energy }\n  }\n"
                 "  interior { ior %.9g",
              tint[0], tint[1], tint[2], mesh->cavity ? 1.0 : mat->ior);
      double amax = 0;
      for (int k = 0; k < 3 && !mesh->cavity; k++)
        amax = mat->absorption[k] > amax ? mat->absorption[k] : amax;
      if (amax > 0)
        /* exp(-(1 - c) d / D) with D = 1 / amax and c = 1 - absorption D. */
        fprintf(f, " fade_power 1001 fade_distance %.9g\n    fade_color rgb <%.9g, %.9g, %.9g>",
                1 / amax, 1 - mat->absorption[0] / amax, 1 - mat->absorption[1] / amax,
                1 - mat->absorption[2] / amax);
      fprintf(f, " }\n  photons { target refraction on reflection %s collect off }\n}\n",
              any_chain ? "on" : "off");
    }
  }
  int bad = ferror(f);
  if (fclose(f) || bad) return fail("cannot write the output");
  bbc_scene_free(scene);
  return 0;
}
