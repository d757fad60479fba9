/* Light tracing of caustic paths and its partition with the caustic estimator
 * (docs/light-tracing.md), against exact irradiance.
 *
 * The scenes, written here: one or two clear glass slabs (ior 1.5, x and z in [-1, 1],
 * flat faces with flat normals) over a diffuse floor (y = 0, [-0.8, 0.8]^2, albedo a,
 * wholly in the slabs' shadow) under a delta sun travelling straight down with irradiance
 * E = 1; a camera at (0, 0.3, 0), under the slabs, looks straight down at the floor. At
 * normal incidence no ray is bent, so every light path through the slabs lands on the
 * floor below where it entered, and the floor's irradiance is exact by enumerating the
 * paths (R = ((n - 1) / (n + 1))^2 = 0.04 at each face, textbook Fresnel):
 *   - the two refractions of one slab alone (chain TT): E (1 - R)^2;
 *   - every path through one slab (2 + 2j vertices, j internal reflection pairs):
 *     T_s = E (1 - R)^2 sum_j R^2j = E (1 - R) / (1 + R);
 *   - every path through two slabs (four or more vertices, none of which the cache can
 *     hold): T_s^2 / (1 - R_s^2), R_s = 1 - T_s = 2R / (1 + R) each slab's reflectance,
 *     the geometric series of the bounces between them.
 * (The depth limit, 16 segments, leaves out paths of more than 14 vertices: terms below
 * R^10 = 1e-14.) A floor pixel's radiance is a / pi times that. Each test's tolerance is
 * four standard errors of the image's mean, estimated from the spread of its pixels
 * (each photon adds to one pixel, so pixels are nearly independent), plus 1e-3 of
 * relative slack for the estimator's part where one is rendered. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/bbc.h"
#include "box_mesh.h"
#include "gltf_shim_internal.h"
#include "harness.h"
#include "json_text.h"
#include "light_trace_internal.h"
#include "render_fixture.h"

#define PI 3.14159265358979323846
#define ALBEDO 0.5
#define FILM 16

/* The glTF text (malloc'd) of the floor and `slabs` (1 or 2) glass slabs 0.1 thick, at
 * y in [0.5, 0.6] and [0.8, 0.9]; and `veils` (0-2) glass faces, each an open surface
 * with its front facing the floor: at y = 1.2, over the slabs, which the light meets from
 * behind, and at y = 0.3, under the camera, which its rays meet from behind. */
static char *slabs_gltf(int slabs, int point, int veils) {
  box_mesh mesh[5];
  memset(mesh, 0, sizeof mesh);
  const double flo[3] = {-0.8, 0, -0.8}, fhi[3] = {0.8, 0, 0.8};
  add_face(&mesh[0], 1, 1, flo, fhi);
  const double lo[4][3] = {{-1, 0.5, -1}, {-1, 0.8, -1}, {-1, 1.2, -1}, {-1, 0.3, -1}},
               hi[4][3] = {{1, 0.6, 1}, {1, 0.9, 1}, {1, 1.2, 1}, {1, 0.3, 1}};
  const double *box_lo[5] = {flo}, *box_hi[5] = {fhi}; /* each mesh's bounds */
  for (int k = 0; k < slabs; k++) {
    for (int a = 0; a < 3; a++)
      for (int s = -1; s <= 1; s += 2) add_face(&mesh[1 + k], a, s, lo[k], hi[k]);
    box_lo[1 + k] = lo[k], box_hi[1 + k] = hi[k];
  }
  for (int v = 0; v < veils; v++) {
    add_face(&mesh[1 + slabs + v], 1, -1, lo[2 + v], hi[2 + v]);
    box_lo[1 + slabs + v] = lo[2 + v], box_hi[1 + slabs + v] = hi[2 + v];
  }
  const int meshes = 1 + slabs + veils;
  char casters[32] = ""; /* the scene's nodes after the floor's: ",3,4..." */
  for (int k = 1; k < meshes; k++)
    snprintf(casters + strlen(casters), sizeof casters - strlen(casters), ",%d", 2 + k);
  unsigned char buf[5 * sizeof(box_mesh)];
  size_t view[15][2];
  const box_mesh *m[5] = {&mesh[0], &mesh[1], &mesh[2], &mesh[3], &mesh[4]};
  const size_t at = box_meshes_pack(m, meshes, buf, view);
  const char *turn = "\"rotation\":[-0.7071067811865476,0,0,0.7071067811865476]";
  json_text t = {0};
  json_printf(&t,
              "{\"asset\":{\"version\":\"2.0\",\"extras\":{\"bbc\":{\"light_units\":"
              "\"radiometric\"}}},\"extensionsUsed\":[\"KHR_lights_punctual\","
              "\"KHR_materials_transmission\",\"KHR_materials_ior\"],"
              "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"name\":\"sun\","
              "\"type\":\"%s\",\"color\":[1,1,1],\"intensity\":1}]}},"
              "\"scene\":0,\"scenes\":[{\"nodes\":[0,1,2%s]}],\"nodes\":["
              "{\"name\":\"sun\",%s,\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}},"
              "{\"name\":\"camera\",\"camera\":0,\"translation\":[0,0.45,0],%s,"
              "\"extras\":{\"bbc\":{\"width\":%d,\"height\":%d}}},"
              "{\"name\":\"floor\",\"mesh\":0,\"extras\":{\"bbc\":{\"role\":\"receiver\"}}}",
              point ? "point" : "directional", casters, point ? "\"translation\":[0,3,0]" : turn,
              turn, FILM, FILM);
  for (int k = 0; k < meshes - 1; k++)
    json_printf(&t,
                ",{\"name\":\"glass%d\",\"mesh\":%d,\"extras\":{\"bbc\":{\"role\":\"caster\"}}}", k,
                1 + k);
  json_printf(&t,
              "],\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":1.2,"
              "\"aspectRatio\":1,\"znear\":0.01}}],"
              "\"materials\":[{\"name\":\"floor\",\"pbrMetallicRoughness\":{\"baseColorFactor\":"
              "[%g,%g,%g,1],\"metallicFactor\":0,\"roughnessFactor\":1}},"
              "{\"name\":\"glass\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,1,1,1],"
              "\"metallicFactor\":0,\"roughnessFactor\":0},\"extensions\":{"
              "\"KHR_materials_transmission\":{\"transmissionFactor\":1},"
              "\"KHR_materials_ior\":{\"ior\":1.5}}}],\"meshes\":[",
              ALBEDO, ALBEDO, ALBEDO);
  for (int k = 0; k < meshes; k++)
    json_printf(&t,
                "%s{\"primitives\":[{\"attributes\":{\"POSITION\":%d,\"NORMAL\":%d},\"indices\":%d,"
                "\"material\":%d,\"mode\":4}]}",
                k ? "," : "", 3 * k, 3 * k + 1, 3 * k + 2, k ? 1 : 0);
  json_printf(&t, "],\"accessors\":[");
  for (int k = 0; k < meshes; k++) {
    const double *l = box_lo[k], *h = box_hi[k];
    int nv = 4 * mesh[k].faces;
    json_printf(&t,
                "%s{\"bufferView\":%d,\"componentType\":5126,\"count\":%d,\"type\":\"VEC3\","
                "\"min\":[%.9g,%.9g,%.9g],\"max\":[%.9g,%.9g,%.9g]},"
                "{\"bufferView\":%d,\"componentType\":5126,\"count\":%d,\"type\":\"VEC3\"},"
                "{\"bufferView\":%d,\"componentType\":5125,\"count\":%d,\"type\":\"SCALAR\"}",
                k ? "," : "", 3 * k, nv, (float)l[0], (float)l[1], (float)l[2], (float)h[0],
                (float)h[1], (float)h[2], 3 * k + 1, nv, 3 * k + 2, 6 * mesh[k].faces);
  }
  json_printf(&t, "],\"bufferViews\":[");
  for (int v = 0; v < 3 * meshes; v++)
    json_printf(&t, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}", v ? "," : "",
                view[v][0], view[v][1]);
  json_printf(
      &t, "],\"buffers\":[{\"byteLength\":%zu,\"uri\":\"data:application/octet-stream;base64,", at);
  json_base64(&t, buf, at);
  json_printf(&t, "\"}]}");
  return t.data;
}

/* The scene of `slabs` slabs, its ray tracer and a TT cache (level 3, grid 16). */
static int setup_veiled(fixture *f, int slabs, int point, int veils) {
  memset(f, 0, sizeof *f);
  char *json = slabs_gltf(slabs, point, veils);
  bbc_result r = bbc__scene_load_memory(&f->scene, json, strlen(json), "slabs.gltf", NULL, NULL);
  free(json);
  if (r != BBC_OK) return 0;
  if (bbc_accel_create(&f->accel, f->scene, NULL, NULL) != BBC_OK) return 0;
  return fixture_cache(f, f->scene, BBC_CHAIN_BIT(BBC_CHAIN_TT), 3, 16, 0);
}

static int setup(fixture *f, int slabs, int point) {
  return setup_veiled(f, slabs, point, 0);
}

/* Textbook Fresnel at normal incidence, and the slabs' exact transmittances. */
static const double R = 0.04; /* ((1.5 - 1) / (1.5 + 1))^2 */
static double slab_all(void) {
  return (1 - R) / (1 + R);
}
static double two_slabs_all(void) {
  double t = slab_all(), r = 1 - t;
  return t * t / (1 - r * r);
}

/* The caustic only, 4 spp, `photons` per sample per pixel. */
static bbc_render_options caustic_options(int light_trace, double bound, uint32_t chains,
                                          uint32_t photons) {
  bbc_render_options o;
  memset(&o, 0, sizeof o);
  o.method = BBC_METHOD_BBC;
  o.components = BBC_COMPONENT_CAUSTICS;
  o.spp = 4;
  o.threads = 2;
  o.seed = 3;
  o.chains = chains;
  o.light_trace = light_trace;
  o.light_trace_bound = bound;
  o.photons_per_spp = photons;
  /* Paths seen directly of at most two specular vertices: no caustic seen after a
   * diffuse bounce (the estimator's at depth 3 needs six segments). */
  o.max_depth = 4;
  return o;
}

/* The mean of the image's first channel and four standard errors of it, estimated from
 * the pixels' deviations from the exact image `exact` (NULL: from their own mean, for an
 * image whose exact pixels are all equal). */
static void mean_and_tolerance_vs(const bbc_image *im, const double *exact, double *mean,
                                  double *tol) {
  const size_t n = (size_t)im->width * im->height;
  double s = 0, s2 = 0;
  for (size_t i = 0; i < n; i++) s += im->rgb[3 * i];
  *mean = s / n;
  for (size_t i = 0; i < n; i++) {
    double d = im->rgb[3 * i] - (exact ? exact[i] : *mean);
    s2 += d * d;
  }
  *tol = 4 * sqrt(s2 / (exact ? n : n - 1)) / sqrt((double)n);
}

static void mean_and_tolerance(const bbc_image *im, double *mean, double *tol) {
  mean_and_tolerance_vs(im, NULL, mean, tol);
}

/* A single slab, light tracing alone (every cell light-traced: the estimator solves
 * nothing at the points the camera sees), every chain type within the depth limit (the
 * two refractions): the exact floor. */
TEST(light_tracing_alone_matches_exact_slab) {
  fixture f;
  REQUIRE(setup(&f, 1, 0));
  bbc_render_stats st;
  bbc_image *im = fixture_render(&f, caustic_options(1, -1, 0, 1u << 18), FILM, FILM, &st);
  REQUIRE(im != NULL);
  double mean, tol;
  mean_and_tolerance(im, &mean, &tol);
  const double exact = ALBEDO / PI * (1 - R) * (1 - R);
  CHECK(st.photon_splats > 10000);
  CHECK(tol < 0.02 * exact);
  CHECK_NEAR(mean, exact, tol);
  CHECK_INT(st.sampled, 0);
  bbc_image_free(im);
  teardown(&f);
}

/* The veil over the slab is glass the sun's light meets from behind, in air, and the veil
 * under the camera glass its rays meet from behind: by the medium rule both go straight
 * through (media_internal.h), so the floor is the bare slab's, exactly, for the caustic
 * estimator alone as for light tracing alone. The estimator's visibility follows the rule
 * too (bbc__media_clear; with every surface stopping light, its image was black), and
 * a surface gone through takes no depth (when it took one, the TT caustic seen through
 * the lower veil, four segments, fell outside the depth limit of 4 and was black). */
TEST(light_goes_through_glass_met_from_behind) {
  fixture f;
  REQUIRE(setup_veiled(&f, 1, 0, 2));
  const double exact = ALBEDO / PI * (1 - R) * (1 - R);
  for (int light_trace = 0; light_trace <= 1; light_trace++) {
    bbc_render_stats st;
    bbc_image *im =
        fixture_render(&f, caustic_options(light_trace, -1, 0, 1u << 18), FILM, FILM, &st);
    REQUIRE(im != NULL);
    double mean, tol;
    mean_and_tolerance(im, &mean, &tol);
    CHECK(tol < 0.02 * exact);
    CHECK_NEAR(mean, exact, fmax(tol, 1e-6 * exact)); /* the estimator's: exact to rounding */
    CHECK(light_trace ? st.photon_splats > 10000 : st.sampled > 0);
    bbc_image_free(im);
  }
  teardown(&f);
}

/* A cache whose chain types leave out the slab's TT (bbc-precompute's default leaves out
 * two-bounce types over its budget, bbc_precompute_choose_chains): the light tracer
 * counts those paths in every cell, so the floor is exact; the control without light
 * tracing is black. */
TEST(light_tracing_covers_chain_types_the_cache_lacks) {
  fixture f;
  REQUIRE(setup(&f, 1, 0));
  bbc_cache_close(f.cache);
  free(f.bytes);
  f.cache = NULL, f.bytes = NULL;
  REQUIRE(fixture_cache(&f, f.scene, BBC_CHAIN_MASK_ALL & ~BBC_CHAIN_MASK_DOUBLE, 3, 16, 0));
  bbc_image *off = fixture_render(&f, caustic_options(0, 0, 0, 1u << 18), FILM, FILM, NULL);
  bbc_render_stats st;
  bbc_image *on = fixture_render(&f, caustic_options(1, INFINITY, 0, 1u << 18), FILM, FILM, &st);
  REQUIRE(off && on);
  const double exact = ALBEDO / PI * (1 - R) * (1 - R);
  double mean, tol;
  mean_and_tolerance(off, &mean, &tol);
  CHECK(mean < 0.01 * exact);
  mean_and_tolerance(on, &mean, &tol);
  CHECK(tol < 0.02 * exact);
  CHECK_NEAR(mean, exact, tol);
  CHECK(st.photon_splats > 10000);
  bbc_image_free(off);
  bbc_image_free(on);
  teardown(&f);
}

static double split_cell_bound(const fixture *f);

/* Byte-identical images for 1 and 2 threads, light tracing and the estimator each taking
 * some of the cells. */
TEST(light_tracing_is_thread_count_independent) {
  fixture f;
  REQUIRE(setup(&f, 1, 1));
  bbc_render_options o = caustic_options(1, split_cell_bound(&f), 0, 1u << 14);
  o.threads = 1;
  bbc_image *one = fixture_render(&f, o, FILM, FILM, NULL);
  o.threads = 2;
  bbc_image *two = fixture_render(&f, o, FILM, FILM, NULL);
  REQUIRE(one && two);
  double sum = 0;
  for (size_t i = 0; i < 3 * FILM * FILM; i++) sum += one->rgb[i];
  CHECK(sum > 0);
  CHECK(memcmp(one->rgb, two->rgb, 3 * FILM * FILM * sizeof(float)) == 0);
  bbc_image_free(one);
  bbc_image_free(two);
  teardown(&f);
}

/* A region's pixels are those of the whole image, light tracing included. */
TEST(light_tracing_region_matches_whole_image) {
  fixture f;
  REQUIRE(setup(&f, 1, 1));
  bbc_render_options o = caustic_options(1, split_cell_bound(&f), 0, 0);
  bbc_image *whole = fixture_render(&f, o, FILM, FILM, NULL);
  const uint32_t region[4] = {3, 5, 11, 13};
  memcpy(o.region, region, sizeof region);
  bbc_image *part = fixture_render(&f, o, FILM, FILM, NULL);
  REQUIRE(whole && part);
  int same = 1, lit = 0;
  for (uint32_t y = region[1]; y < region[3]; y++)
    for (uint32_t x = region[0]; x < region[2]; x++) {
      const float *a = whole->rgb + 3 * (y * FILM + x), *b = part->rgb + 3 * (y * FILM + x);
      same &= memcmp(a, b, 3 * sizeof(float)) == 0;
      lit += a[0] > 0;
    }
  CHECK(same);
  CHECK(lit > 0);
  bbc_image_free(whole);
  bbc_image_free(part);
  teardown(&f);
}

/* Two slabs: every light path to the floor has four or more specular vertices, which no
 * cache holds. Without light tracing the floor is black; with it (default cells), exact. */
TEST(light_tracing_renders_four_vertex_chains) {
  fixture f;
  REQUIRE(setup(&f, 2, 0));
  bbc_render_options o = caustic_options(0, 0, 0, 1u << 18);
  o.max_depth = 16;
  bbc_image *off = fixture_render(&f, o, FILM, FILM, NULL);
  o.light_trace = 1;
  bbc_image *on = fixture_render(&f, o, FILM, FILM, NULL);
  REQUIRE(off && on);
  const double exact = ALBEDO / PI * two_slabs_all();
  double mean, tol;
  mean_and_tolerance(off, &mean, &tol);
  CHECK(mean < 0.01 * exact); /* the control: today's image lacks them */
  mean_and_tolerance(on, &mean, &tol);
  CHECK(tol < 0.02 * exact);
  CHECK_NEAR(mean, exact, tol);
  bbc_image_free(off);
  bbc_image_free(on);
  teardown(&f);
}

/* Without a cache (the path tracer alone), light tracing counts every caustic path of
 * the lights, one slab's two refractions (Fresnel-weighted, the floor seen directly)
 * and two slabs' four and more: the exact floors. The control without light tracing is
 * black (a path tracer never meets a point light through glass). */
TEST(light_tracing_without_a_cache_is_exact) {
  for (int slabs = 1; slabs <= 2; slabs++) {
    fixture f;
    REQUIRE(setup(&f, slabs, 0));
    bbc_render_options o = caustic_options(0, 0, 0, 1u << 18);
    o.method = BBC_METHOD_PT;
    o.max_depth = 16;
    bbc_image *off = fixture_render(&f, o, FILM, FILM, NULL);
    o.light_trace = 1;
    bbc_render_stats st;
    bbc_image *on = fixture_render(&f, o, FILM, FILM, &st);
    REQUIRE(off && on);
    const double exact = ALBEDO / PI * (slabs == 1 ? slab_all() : two_slabs_all());
    double mean, tol;
    mean_and_tolerance(off, &mean, &tol);
    CHECK(mean < 0.01 * exact);
    mean_and_tolerance(on, &mean, &tol);
    fprintf(stderr, "%d slab(s) without a cache: %.6f, exact %.6f (tolerance %.6f)\n", slabs, mean,
            exact, tol);
    CHECK(st.photon_splats > 10000);
    CHECK(tol < 0.02 * exact);
    CHECK_NEAR(mean, exact, tol);
    bbc_image_free(off);
    bbc_image_free(on);
    teardown(&f);
  }
}

/* A bound that splits the cells the pixels' centres see: some have a TT tuple bounded
 * by at least it, some not (NaN if none does). */
static double split_cell_bound(const fixture *f) {
  bbc_cache_cursor *cursor = NULL;
  if (bbc_cache_cursor_create(&cursor, f->cache) != BBC_OK) return NAN;
  double b[FILM * FILM];
  int n = 0;
  const bbc_tuple *tuples = bbc_cache_tuples(f->cache);
  for (int y = 0; y < FILM; y++)
    for (int x = 0; x < FILM; x++) {
      bbc_vec3 o, d;
      bbc_camera_ray(&f->scene->camera, FILM, FILM, x + 0.5, y + 0.5, &o, &d);
      bbc_hit hit;
      if (!bbc_accel_intersect(f->accel, o, d, 0, INFINITY, &hit)) continue;
      bbc_vec3 p = {o.x + hit.t * d.x, o.y + hit.t * d.y, o.z + hit.t * d.z};
      const bbc_cache_entry *e = NULL;
      uint32_t count = 0;
      if (bbc_cache_lookup(cursor, hit.triangle, hit.u, hit.v, &p, &e, &count) != BBC_OK) continue;
      double most = 0;
      for (uint32_t i = 0; i < count; i++)
        if (tuples[e[i].tuple].chain == BBC_CHAIN_TT) most = fmax(most, e[i].bound);
      b[n++] = most;
    }
  bbc_cache_cursor_free(cursor);
  for (int i = 1; i < n; i++)
    for (int j = i; j > 0 && b[j - 1] > b[j]; j--) {
      double t = b[j];
      b[j] = b[j - 1];
      b[j - 1] = t;
    }
  /* The first value above the smallest from the median on: a split that leaves cells on
   * both sides. */
  for (int i = n / 2; i < n; i++)
    if (b[i] > b[0]) return b[i];
  for (int i = 0; i < n; i++)
    if (b[i] > b[0]) return b[i];
  return NAN;
}

/* Textbook Fresnel reflectance from index n1 into n2 at incidence cosine c. */
static double fresnel(double c, double n1, double n2) {
  double sin_t = n1 / n2 * sqrt(fmax(0.0, 1 - c * c));
  if (sin_t >= 1) return 1;
  double ct = sqrt(1 - sin_t * sin_t);
  double rs = (n1 * c - n2 * ct) / (n1 * c + n2 * ct);
  double rp = (n2 * c - n1 * ct) / (n2 * c + n1 * ct);
  return 0.5 * (rs * rs + rp * rp);
}

/* The point light (I = 1, 2.4 above the slab's top, 3 above the floor) through the
 * slab (thickness 0.1, 0.5 above the floor): the floor's irradiance at distance r from
 * the foot of the light, by the two refractions. A ray leaving at angle t to the vertical
 * lands at r(t) = 2.9 tan t + 0.1 tan t', sin t' = sin t / 1.5; the flux I T 2 pi sin t dt
 * of the cone between t and t + dt covers the annulus 2 pi r dr, so
 * E = I T sin t / (r dr/dt), T the two Fresnel transmittances. */
static double point_slab_irradiance(double r) {
  double lo = 0, hi = 1.5; /* bisection on t: r(t) increases */
  for (int it = 0; it < 100; it++) {
    double t = 0.5 * (lo + hi), tt = asin(sin(t) / 1.5);
    if (2.9 * tan(t) + 0.1 * tan(tt) < r)
      lo = t;
    else
      hi = t;
  }
  double t = 0.5 * (lo + hi), tt = asin(sin(t) / 1.5);
  double drdt = 2.9 / (cos(t) * cos(t)) + 0.1 * cos(t) / (1.5 * pow(cos(tt), 3));
  double transmit = (1 - fresnel(cos(t), 1, 1.5)) * (1 - fresnel(cos(tt), 1.5, 1));
  return transmit * sin(t) / (r * drdt);
}

/* The exact image: a / pi E averaged over 8 x 8 points of each pixel; returns its mean. */
static double point_slab_exact(const bbc_camera *camera, double pixels[FILM * FILM]) {
  double sum = 0;
  for (int py = 0; py < FILM; py++)
    for (int px = 0; px < FILM; px++) {
      double pixel = 0;
      for (int k = 0; k < 64; k++) {
        bbc_vec3 o, d;
        bbc_camera_ray(camera, FILM, FILM, px + (k % 8 + 0.5) / 8, py + (k / 8 + 0.5) / 8, &o, &d);
        double t = -o.y / d.y;
        pixel += ALBEDO / PI * point_slab_irradiance(hypot(o.x + t * d.x, o.z + t * d.z)) / 64;
      }
      pixels[py * FILM + px] = pixel;
      sum += pixel;
    }
  return sum / (FILM * FILM);
}

/* The point light over the slab (TT), its exact image and mean, and a bound that splits
 * its cells between the estimator and light tracing. */
static int setup_split(fixture *f, double pixels[FILM * FILM], double *exact, double *split) {
  if (!setup(f, 1, 1)) return 0;
  *exact = point_slab_exact(&f->scene->camera, pixels);
  *split = split_cell_bound(f);
  return *split > 0 && isfinite(*split);
}

/* A point light over the slab, TT only, against the exact image. The cells split at the
 * median bound (the bounds fall with the distance from the light): some pixels from the
 * estimator, some from light tracing, the mean exact. The control, both strategies on
 * every cell (the estimator's image plus light tracing's alone), counts each path twice
 * and fails the same check. */
TEST(partition_counts_each_path_once) {
  fixture f;
  double pixels[FILM * FILM], exact, split;
  REQUIRE(setup_split(&f, pixels, &exact, &split));
  const uint32_t tt = BBC_CHAIN_BIT(BBC_CHAIN_TT);
  bbc_image *estimator = fixture_render(&f, caustic_options(0, 0, tt, 1u << 18), FILM, FILM, NULL);
  bbc_image *traced = fixture_render(&f, caustic_options(1, -1, tt, 1u << 18), FILM, FILM, NULL);
  bbc_image *both = fixture_render(&f, caustic_options(1, split, tt, 1u << 18), FILM, FILM, NULL);
  REQUIRE(estimator && traced && both);
  double mean, tol;
  mean_and_tolerance_vs(estimator, pixels, &mean, &tol);
  CHECK_NEAR(mean, exact, tol + 1e-3 * exact);
  double traced_mean, traced_tol;
  mean_and_tolerance_vs(traced, pixels, &traced_mean, &traced_tol);
  CHECK_NEAR(traced_mean, exact, traced_tol);
  /* The control: counted twice. */
  CHECK(fabs(mean + traced_mean - exact) > 0.5 * exact);
  mean_and_tolerance_vs(both, pixels, &mean, &tol);
  CHECK(tol < 0.05 * exact); /* far below the control's error */
  CHECK_NEAR(mean, exact, tol + 1e-3 * exact);
  /* Both strategies drew pixels: some equal the estimator's alone, others light
   * tracing's alone. */
  int from_estimator = 0, from_tracing = 0;
  for (size_t i = 0; i < FILM * FILM; i++) {
    from_estimator +=
        both->rgb[3 * i] == estimator->rgb[3 * i] && both->rgb[3 * i] != traced->rgb[3 * i];
    from_tracing +=
        both->rgb[3 * i] == traced->rgb[3 * i] && both->rgb[3 * i] != estimator->rgb[3 * i];
  }
  CHECK(from_estimator > FILM * FILM / 8);
  CHECK(from_tracing > FILM * FILM / 8);
  bbc_image_free(estimator);
  bbc_image_free(traced);
  bbc_image_free(both);
  teardown(&f);
}

/* Aimed photons (docs/light-tracing.md, "Aimed photons") and the cones' photons split the
 * light-traced paths by the first triangle they meet: with many of both, on the cells
 * split as above, the image is exact, as with the cones' photons alone, and differs from
 * it. Were the cones' photons to count the aimed photons' paths too, the light-traced
 * half of the image would read double (checked by letting them: 1.6x the exact mean). */
TEST(aimed_photons_count_each_path_once) {
  fixture f;
  double pixels[FILM * FILM], exact, split;
  REQUIRE(setup_split(&f, pixels, &exact, &split));
  const uint32_t tt = BBC_CHAIN_BIT(BBC_CHAIN_TT);
  bbc_render_options o = caustic_options(1, split, tt, 1u << 16);
  o.aimed_photons_per_spp = 1u << 16;
  bbc_render_stats st;
  bbc_image *aimed = fixture_render(&f, o, FILM, FILM, &st);
  o.aimed_photons_per_spp = BBC_AIMED_PHOTONS_OFF;
  bbc_image *cones = fixture_render(&f, o, FILM, FILM, NULL);
  REQUIRE(aimed && cones);
  CHECK(st.photons == 4 * (2u << 16)); /* counts given are kept */
  double mean, tol;
  mean_and_tolerance_vs(aimed, pixels, &mean, &tol);
  CHECK(tol < 0.05 * exact);
  CHECK_NEAR(mean, exact, tol + 1e-3 * exact);
  mean_and_tolerance_vs(cones, pixels, &mean, &tol);
  CHECK_NEAR(mean, exact, tol + 1e-3 * exact);
  CHECK(memcmp(aimed->rgb, cones->rgb, 3 * FILM * FILM * sizeof(float)) != 0);
  bbc_image_free(aimed);
  bbc_image_free(cones);
  teardown(&f);
}

/* The photon counts after sample 0: the aimed photons' default scaled by 32 times the
 * share of them that reached a pixel, within [1/8, 1]; the cones' and a count given
 * kept; the photon indices of each sample in a row. */
TEST(photon_counts_follow_the_pilots_share) {
  bbc__light_tracer lt;
  memset(&lt, 0, sizeof lt);
  lt.aim_count = 1;
  const uint64_t defaults[2] = {6400, 6400}, given[2] = {0, 0};
  bbc__light_tracer_budget(&lt, defaults, given);
  CHECK(lt.aiming && lt.pilot[0] == 6400 && lt.pilot[1] == 6400);
  bbc__light_tracer_adapt(&lt, 400); /* a share of 1/16 */
  CHECK(lt.rest[0] == 6400 && lt.rest[1] == 6400);
  bbc__light_tracer_adapt(&lt, 40); /* 1/160 */
  CHECK(lt.rest[0] == 6400 && lt.rest[1] == 1280);
  bbc__light_tracer_adapt(&lt, 0);
  CHECK(lt.rest[0] == 6400 && lt.rest[1] == 800);
  CHECK(bbc__light_tracer_first_photon(&lt, 0) == 0);
  CHECK(bbc__light_tracer_first_photon(&lt, 1) == 12800);
  CHECK(bbc__light_tracer_first_photon(&lt, 3) == 12800 + 2 * 7200);
  const uint64_t fixed[2] = {1000, UINT64_MAX}; /* --photons 1000 --aimed-photons off */
  bbc__light_tracer_budget(&lt, defaults, fixed);
  bbc__light_tracer_adapt(&lt, 0);
  CHECK(!lt.aiming && lt.rest[0] == 1000 && lt.rest[1] == 0);
}
