/* bbc-inspect: shows, validates and draws .bbc caches (format-spec/bbc-format.md).
 * In the manner of OpenEXR's exrinfo: one subcommand per question, data on stdout,
 * diagnostics on stderr, exit 1 for a bad file and 2 for bad usage. */
#include <errno.h>
#include <math.h>
#include <omp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/cache.h"
#include "bbc/common.h"
#include "bbc/grid.h"
#include "bbc/image.h"
#include "bbc/precompute.h"
#include "bbc/scene.h"
#include "bbc/solver.h"
#include "bbc/specular_path.h"
#include "bbc/tuple.h"
#include "bbc/validate.h"
#include "cli.h"

static const char usage[] =
    "usage: bbc-inspect info CACHE.bbc\n"
    "       bbc-inspect validate CACHE.bbc\n"
    "       bbc-inspect dump CACHE.bbc --cell X,Y [--receiver R]\n"
    "       bbc-inspect heatmap CACHE.bbc -o OUT.exr [--receiver R] [--log10]\n"
    "       bbc-inspect check-bounds SCENE.gltf CACHE.bbc [--samples N] [--json FILE]\n"
    "                   [--threads N] [--progress|--no-progress] [--light-units U]\n"
    "       bbc-inspect solutions SCENE.gltf CACHE.bbc [--samples N] [--threads N]\n"
    "                   [--light-units U]\n"
    "       bbc-inspect diff A.bbc B.bbc\n"
    "       bbc-inspect merge OUT.bbc SHARD.bbc... [--threads N] [--progress|--no-progress]\n"
    "       bbc-inspect -h|--help | --version\n";

static const char help[] =
    "bbc-inspect: shows, validates and draws .bbc caches of bbc-precompute.\n"
    "\n"
    "usage: bbc-inspect COMMAND CACHE.bbc [OPTIONS]\n"
    "\n"
    "Commands:\n"
    "  info CACHE.bbc       the header, every section (offset, size, checksum), the\n"
    "                       precompute parameters, the fingerprint, the counts (tuples per\n"
    "                       chain, receivers and their grids, cells, entries, chunks) and\n"
    "                       the compression ratio of the cell lists\n"
    "  validate CACHE.bbc   checks every structural rule and every checksum, decoding every\n"
    "                       chunk and cell list; prints one line per problem to stderr and\n"
    "                       exits 1 if there is any, else prints a summary and exits 0\n"
    "  dump CACHE.bbc       prints one cell's list: tuple id, chain, light, specular\n"
    "                       triangles T1 T2, receiver triangle and irradiance bound\n"
    "      --cell X,Y         the cell (column X, row Y of the receiver's grid); required\n"
    "      --receiver R       the receiver (default 0)\n"
    "  heatmap CACHE.bbc    writes, per receiver, the sum of the bounds of each cell as a\n"
    "                       grey EXR image (image row y is grid row y)\n"
    "      -o, --output OUT.exr  the image; with several receivers and no --receiver,\n"
    "                       OUT.<R>.exr for each receiver R\n"
    "      --receiver R       only receiver R, written to OUT.exr\n"
    "      --log10            log10 of the sum (empty cells -inf, unbounded cells +inf)\n"
    "  check-bounds SCENE.gltf CACHE.bbc\n"
    "                       checks the cache against true paths (the paper's Fig. 17/18):\n"
    "                       for every candidate tuple of the cache's chain types (stored\n"
    "                       or not), traces N sampled paths and checks that each\n"
    "                       admissible one is listed in its cell with a bound at least\n"
    "                       its irradiance; prints per chain type (R, T, RR, RT, TR, TT)\n"
    "                       a summary and a histogram of\n"
    "                       log10(stored bound / true irradiance); exits 1 if any path\n"
    "                       breaks a bound (the first one is printed), else 0. The cache\n"
    "                       must have been computed for SCENE (else exit 1)\n"
    "      --samples N        paths per tuple (default 100)\n"
    "      --json FILE        also writes {\"R\": {...}, \"T\": {...}, ...} to FILE\n"
    "      --threads N        threads (default: all cores); the output does not depend on it\n"
    "      --progress, --no-progress  force the progress bar on stderr on or off (default:\n"
    "                       on when stderr is a terminal)\n"
    "      --light-units U    photometric or radiometric, as for bbc-precompute\n"
    "  solutions SCENE.gltf CACHE.bbc\n"
    "                       counts the solutions per tuple (the paper's Fig. 8): N sampled\n"
    "                       shading points per receiver triangle, each solved with every\n"
    "                       one-bounce tuple of its cell that ends on that triangle; prints\n"
    "                       the histogram of solutions per (point, tuple) (0, 1, 2, 3, 4+)\n"
    "                       and the share with more than the cache's m\n"
    "      --samples N        shading points per receiver triangle (default 256)\n"
    "      --threads N        threads (default: all cores); the output does not depend on it\n"
    "      --light-units U    photometric or radiometric, as for bbc-precompute\n"
    "  diff A.bbc B.bbc     what differs between two caches: parameters, fingerprints,\n"
    "                       tuples (count, first difference), receivers and grids, and cell\n"
    "                       lists (count of differing cells, the first with both lists);\n"
    "                       prints nothing and exits 0 when they agree, 1 when they differ\n"
    "  merge OUT.bbc SHARD.bbc...\n"
    "                       joins the shard caches of one sharded precompute\n"
    "                       (bbc-precompute --shard I/N for I = 0..N-1, in any order) into\n"
    "                       OUT.bbc, byte-identical to the cache of the same precompute\n"
    "                       without --shard. Refuses, with one line and exit 1, a cache\n"
    "                       that is not a shard, shards of other scenes, parameters or\n"
    "                       splits, a shard given twice and a missing shard. OUT.bbc is\n"
    "                       written to a temporary file and renamed: never half-written\n"
    "      --threads N        threads (default: all cores); the output does not depend on it\n"
    "      --progress, --no-progress  force the progress bar on stderr on or off\n"
    "\n"
    "Options:\n"
    "  -h, --help           this text\n"
    "  --version            the versions of bbc-inspect, libbbc and the .bbc format\n"
    "\n"
    "Exit status: 0 success, 1 a file could not be read or is invalid (check-bounds: a\n"
    "bound is broken; diff: the caches differ; merge: the shards do not merge), 2 bad\n"
    "usage, 130 when merge is interrupted (OUT.bbc is then not written).\n";

static bbc_cache *open_cache(const char *path) {
  bbc_cache_options o = {cli_print_first_message, NULL, 0};
  bbc_cache *c = NULL;
  if (bbc_cache_open(&c, path, &o) != BBC_OK) exit(1); /* the callback printed the line */
  return c;
}

static const char *chains_text(uint32_t mask, char *out, size_t size) {
  out[0] = '\0';
  for (int c = 0; c < BBC_CHAIN_COUNT; c++)
    if (mask & BBC_CHAIN_BIT(c)) {
      size_t n = strlen(out);
      snprintf(out + n, size - n, "%s%s", n ? "," : "", bbc_chain_name((bbc_chain)c));
    }
  return out;
}

static int cmd_info(const char *path) {
  bbc_cache *c = open_cache(path);
  bbc_cache_info in;
  bbc_cache_get_info(c, &in);
  printf("file         %s\n", path);
  printf("format       %u.%u (this reader: %d.%d)\n", in.version_major, in.version_minor,
         BBC_FORMAT_VERSION_MAJOR, BBC_FORMAT_VERSION_MINOR);
  printf("file size    %llu bytes\n", (unsigned long long)in.file_size);
  printf("writer       %s\n", in.writer[0] ? in.writer : "(no INFO section)");
  printf("sections     %u\n", in.section_count);
  for (uint32_t i = 0; i < in.section_count; i++) {
    bbc_cache_section s;
    bbc_cache_get_section(c, i, &s);
    printf("  %-4s  %-8s  offset %10llu  size %12llu  crc32 0x%08x\n", s.name,
           (s.flags & 1) ? "required" : "optional", (unsigned long long)s.offset,
           (unsigned long long)s.size, s.checksum);
  }
  char chains[64];
  const bbc_precompute_params *p = &in.params;
  printf(
      "parameters   chains %s, max_level %u, sigma %g, alpha %g (one bounce) %g (two), "
      "m %g, grid %u, remainder %s\n",
      chains_text(p->chains, chains, sizeof chains), p->max_level, p->sigma, p->alpha_single,
      p->alpha_double, p->m, p->grid_resolution, p->remainder ? "on" : "off");
  const bbc_fingerprint *f = &in.fingerprint;
  printf(
      "fingerprint  %016llx (geometry %016llx, materials %016llx, meshes %016llx, "
      "lights %016llx, parameters %016llx)\n",
      (unsigned long long)f->total, (unsigned long long)f->geometry,
      (unsigned long long)f->materials, (unsigned long long)f->meshes,
      (unsigned long long)f->lights, (unsigned long long)f->params);
  printf("scene        %u vertices, %u triangles, %u meshes, %u materials, %u lights\n",
         in.scene_vertex_count, in.scene_triangle_count, in.scene_mesh_count,
         in.scene_material_count, in.scene_light_count);
  uint64_t per_chain[BBC_CHAIN_COUNT] = {0};
  const bbc_tuple *t = bbc_cache_tuples(c);
  for (uint32_t i = 0; i < in.tuple_count; i++) per_chain[t[i].chain]++;
  bbc_cache_shard shard;
  if (bbc_cache_get_shard(c, &shard))
    printf(
        "shard        %u/%u of a sharded precompute: %u of its %llu candidate tuples stored "
        "(candidates hash %016llx); incomplete alone, merge all %u with bbc-inspect merge\n",
        shard.index, shard.count, in.tuple_count, (unsigned long long)shard.candidate_count,
        (unsigned long long)shard.candidates_hash, shard.count);
  printf("tuples       %u", in.tuple_count);
  int listed = 0;
  for (int k = 0; k < BBC_CHAIN_COUNT; k++)
    if (per_chain[k])
      printf("%s%s %llu", listed++ ? ", " : " (", bbc_chain_name((bbc_chain)k),
             (unsigned long long)per_chain[k]);
  printf("%s\n", listed ? ")" : "");
  cli_print_tuples_per_light(stdout, "  ", t, in.tuple_count,
                             in.scene_light_count + in.scene_emitter_count, NULL);
  const bbc_grid *g = bbc_cache_grid(c);
  printf("receivers    %u\n", in.receiver_count);
  for (uint32_t i = 0; i < g->receiver_count; i++) {
    const bbc_receiver *r = &g->receivers[i];
    printf("  %u: mesh %u, %s, %u x %u cells, triangles %u..%u, domain [%g, %g] x [%g, %g]\n", i,
           r->mesh, bbc_parameterisation_name(r->parameterisation), r->width, r->height,
           r->first_triangle, r->first_triangle + r->triangle_count - 1, r->domain[0], r->domain[2],
           r->domain[1], r->domain[3]);
  }
  printf("cells        %llu, %llu with a list\n", (unsigned long long)in.cell_count,
         (unsigned long long)in.nonempty_cell_count);
  printf("entries      %llu (%.1f per non-empty cell)\n", (unsigned long long)in.entry_count,
         in.nonempty_cell_count ? (double)in.entry_count / (double)in.nonempty_cell_count : 0.0);
  printf("chunks       %u\n", in.chunk_count);
  printf("cell lists   %llu bytes decoded, %llu compressed, ratio %.2f\n",
         (unsigned long long)in.decoded_bytes, (unsigned long long)in.compressed_bytes,
         in.compressed_bytes ? (double)in.decoded_bytes / (double)in.compressed_bytes : 0.0);
  bbc_cache_close(c);
  return 0;
}

typedef struct problems {
  int count;
} problems;

static void on_problem(void *user, bbc_result code, const char *message) {
  ((problems *)user)->count++;
  cli_print_message(NULL, code, message);
}

static int cmd_validate(const char *path) {
  bbc_cache *c = open_cache(path);
  problems pr = {0};
  bbc_result r = bbc_cache_validate(c, on_problem, &pr);
  if (r != BBC_OK) {
    bbc_cache_close(c);
    return 1;
  }
  bbc_cache_info in;
  bbc_cache_get_info(c, &in);
  bbc_cache_shard shard;
  char shard_text[64] = "";
  if (bbc_cache_get_shard(c, &shard))
    snprintf(shard_text, sizeof shard_text, "shard %u/%u, ", shard.index, shard.count);
  printf("%s: valid (format %u.%u, %s%u tuples, %u receivers, %u chunks, %llu entries)\n", path,
         in.version_major, in.version_minor, shard_text, in.tuple_count, in.receiver_count,
         in.chunk_count, (unsigned long long)in.entry_count);
  bbc_cache_close(c);
  return 0;
}

static uint32_t parse_receiver(const cli_args *a, const char *text, const bbc_grid *g) {
  long long r = cli_parse_int(a, "--receiver", text, 0, UINT32_MAX);
  if ((uint64_t)r >= g->receiver_count)
    cli_usage_error(a->usage, "--receiver: %lld, the cache has %u receivers", r, g->receiver_count);
  return (uint32_t)r;
}

static void parse_cell(const cli_args *a, const char *text, long long *x, long long *y) {
  const char *comma = strchr(text, ',');
  if (!comma) cli_usage_error(a->usage, "--cell: '%s' is not X,Y", text);
  char left[64];
  size_t n = (size_t)(comma - text);
  if (n >= sizeof left) cli_usage_error(a->usage, "--cell: '%s' is not X,Y", text);
  memcpy(left, text, n);
  left[n] = '\0';
  *x = cli_parse_int(a, "--cell", left, 0, UINT32_MAX);
  *y = cli_parse_int(a, "--cell", comma + 1, 0, UINT32_MAX);
}

static int cmd_dump(cli_args *a, const char *path) {
  const char *cell_text = NULL, *receiver_text = NULL;
  while (a->i < a->argc) {
    const char *v;
    if (cli_option(a, "--cell", &v))
      cell_text = v;
    else if (cli_option(a, "--receiver", &v))
      receiver_text = v;
    else
      cli_usage_error(usage, "unknown option '%s'", a->argv[a->i]);
  }
  if (!cell_text) cli_usage_error(usage, "dump needs --cell X,Y");
  long long x, y;
  parse_cell(a, cell_text, &x, &y);
  bbc_cache *c = open_cache(path);
  const bbc_grid *g = bbc_cache_grid(c);
  uint32_t r = receiver_text ? parse_receiver(a, receiver_text, g) : 0;
  const bbc_receiver *rc = &g->receivers[r];
  if (x >= rc->width || y >= rc->height)
    cli_usage_error(usage, "--cell: %lld,%lld is outside the %u x %u grid of receiver %u", x, y,
                    rc->width, rc->height, r);
  bbc_cache_cursor *cur = NULL;
  if (bbc_cache_cursor_create(&cur, c) != BBC_OK) cli_fail("out of memory");
  const bbc_cache_entry *e;
  uint32_t n;
  uint64_t index = bbc_grid_cell_index(g, (bbc_cell){r, (uint32_t)x, (uint32_t)y});
  if (bbc_cache_cell(cur, index, &e, &n) != BBC_OK) exit(1); /* the callback printed it */
  const bbc_tuple *t = bbc_cache_tuples(c);
  printf("# receiver %u, cell %lld,%lld: %u entries\n", r, x, y, n);
  printf("# tuple chain light T1 T2 receiver bound\n");
  for (uint32_t i = 0; i < n; i++) {
    const bbc_tuple *u = &t[e[i].tuple];
    char t2[16];
    if (u->specular[1] == BBC_NO_TRIANGLE)
      snprintf(t2, sizeof t2, "-");
    else
      snprintf(t2, sizeof t2, "%u", u->specular[1]);
    printf("%u %s %u %u %s %u %.9g\n", e[i].tuple, bbc_chain_name((bbc_chain)u->chain), u->light,
           u->specular[0], t2, u->receiver, (double)e[i].bound);
  }
  bbc_cache_cursor_free(cur);
  bbc_cache_close(c);
  return 0;
}

/* OUT.exr -> OUT.<r>.exr (or OUT.<r> without an .exr ending). */
static void receiver_path(const char *out, uint32_t r, char *buf, size_t size) {
  size_t n = strlen(out);
  if (n > 4 && strcmp(out + n - 4, ".exr") == 0)
    snprintf(buf, size, "%.*s.%u.exr", (int)(n - 4), out, r);
  else
    snprintf(buf, size, "%s.%u", out, r);
}

static int cmd_heatmap(cli_args *a, const char *path) {
  const char *out = NULL, *receiver_text = NULL;
  int log10_sum = 0;
  while (a->i < a->argc) {
    const char *v;
    if (cli_option(a, "-o", &v) || cli_option(a, "--output", &v))
      out = v;
    else if (cli_option(a, "--receiver", &v))
      receiver_text = v;
    else if (cli_flag(a, "--log10"))
      log10_sum = 1;
    else
      cli_usage_error(usage, "unknown option '%s'", a->argv[a->i]);
  }
  if (!out) cli_usage_error(usage, "heatmap needs -o OUT.exr");
  bbc_cache *c = open_cache(path);
  const bbc_grid *g = bbc_cache_grid(c);
  uint32_t first = 0, last = g->receiver_count - 1;
  if (receiver_text) first = last = parse_receiver(a, receiver_text, g);
  bbc_cache_cursor *cur = NULL;
  if (bbc_cache_cursor_create(&cur, c) != BBC_OK) cli_fail("out of memory");
  for (uint32_t r = first; r <= last; r++) {
    const bbc_receiver *rc = &g->receivers[r];
    bbc_image *img = NULL;
    if (bbc_image_create(&img, rc->width, rc->height) != BBC_OK) cli_fail("out of memory");
    for (uint32_t y = 0; y < rc->height; y++)
      for (uint32_t x = 0; x < rc->width; x++) {
        const bbc_cache_entry *e;
        uint32_t n;
        if (bbc_cache_cell(cur, bbc_grid_cell_index(g, (bbc_cell){r, x, y}), &e, &n) != BBC_OK)
          exit(1);
        double sum = 0;
        for (uint32_t i = 0; i < n; i++) sum += e[i].bound;
        float v = (float)(log10_sum ? log10(sum) : sum);
        float *px = &img->rgb[3 * ((size_t)y * rc->width + x)];
        px[0] = px[1] = px[2] = v;
      }
    char buf[4096];
    const char *target = out;
    if (first != last) {
      receiver_path(out, r, buf, sizeof buf);
      target = buf;
    }
    bbc_result res = bbc_image_write_exr(img, target, cli_print_message, NULL);
    bbc_image_free(img);
    if (res != BBC_OK) exit(1);
  }
  bbc_cache_cursor_free(cur);
  bbc_cache_close(c);
  return 0;
}

/* ------------------------------------------------------------------ check-bounds */

static bbc_scene *load_scene(const char *path, bbc_light_units light_units) {
  bbc_scene_options o = {cli_print_message, cli_print_warning, NULL, light_units};
  bbc_scene *s = NULL;
  if (bbc_scene_load(&s, path, &o) != BBC_OK) exit(1); /* the callback printed the line */
  return s;
}

/* Opens the cache and refuses one of another scene (one line from the callback). */
static bbc_cache *open_cache_for(const char *path, const bbc_scene *scene) {
  bbc_cache *c = open_cache(path);
  if (bbc_cache_check_scene(c, scene) != BBC_OK) exit(1);
  return c;
}

static void set_threads(const cli_args *a, const char *text) {
  if (text) omp_set_num_threads((int)cli_parse_int(a, "--threads", text, 1, 4096));
}

/* Tuples per block of check-bounds. Each block has its own accumulators, merged in block
 * order: the blocks do not depend on the thread count, so neither do the sums of
 * floating-point ratios (per-thread accumulators would make them depend on it). */
#define CHECK_BLOCK 16

static void print_failure(const char *label, const bbc_validation_failure *f, FILE *out) {
  static const char *const kinds[] = {"position", "upper", "lower", "discarded", "uncovered"};
  fprintf(out,
          "%s: first failure: tuple (light %u, T1 %u, receiver %u), sample %u, u1 (%.9g, %.9g), "
          "uk (%.9g, %.9g), irradiance %.9g, kinds",
          label, f->tuple.light, f->tuple.specular[0], f->tuple.receiver, f->sample, f->u1[0],
          f->u1[1], f->uk[0], f->uk[1], f->irradiance);
  int n = 0;
  for (int k = 0; k < 5; k++)
    if (f->kinds & (1u << k)) fprintf(out, "%s%s", n++ ? "," : " ", kinds[k]);
  fprintf(out, "\n");
}

static void write_validation_json(const char *path, const bbc_validation *acc) {
  char tmp[4096];
  snprintf(tmp, sizeof tmp, "%s.tmp", path);
  FILE *f = fopen(tmp, "w");
  if (!f) cli_fail("%s: cannot write: %s", path, strerror(errno));
  int bad = 0;
  for (int k = 0; k < BBC_CHAIN_COUNT; k++) {
    bad |= fprintf(f, "%s\"%s\": ", k ? ", " : "{", bbc_chain_name((bbc_chain)k)) < 0;
    bad |= bbc_validation_write_json(&acc[k], f) != BBC_OK;
  }
  bad |= fputs("}\n", f) < 0;
  bad |= ferror(f) != 0;
  bad |= fclose(f) != 0;
  if (bad || rename(tmp, path) != 0) {
    int e = errno;
    remove(tmp);
    cli_fail("%s: cannot write: %s", path, strerror(e));
  }
}

static int cmd_check_bounds(cli_args *a, const char *scene_path, const char *cache_path) {
  const char *samples_text = NULL, *json = NULL, *threads_text = NULL;
  int progress = -1;
  bbc_light_units light_units = BBC_LIGHT_UNITS_FILE;
  while (a->i < a->argc) {
    const char *v;
    if (cli_option(a, "--samples", &v))
      samples_text = v;
    else if (cli_option(a, "--json", &v))
      json = v;
    else if (cli_option(a, "--threads", &v))
      threads_text = v;
    else if (cli_flag(a, "--progress"))
      progress = 1;
    else if (cli_flag(a, "--no-progress"))
      progress = 0;
    else if (cli_option(a, "--light-units", &v))
      light_units = cli_parse_light_units(a, "--light-units", v);
    else
      cli_usage_error(usage, "unknown option '%s'", a->argv[a->i]);
  }
  uint32_t samples =
      samples_text ? (uint32_t)cli_parse_int(a, "--samples", samples_text, 1, UINT32_MAX) : 100;
  set_threads(a, threads_text);

  bbc_scene *scene = load_scene(scene_path, light_units);
  bbc_cache *c = open_cache_for(cache_path, scene);
  bbc_cache_info in;
  bbc_cache_get_info(c, &in);
  bbc_tuple *cand = NULL;
  size_t count = 0;
  if (bbc_tuples_find(scene, in.params.chains, &cand, &count) != BBC_OK)
    cli_fail("%s: cannot list the candidate tuples (out of memory)", scene_path);
  if (in.params.area_lights) {
    /* The area lights' candidates follow the punctual lights' (bbc_precompute). */
    bbc_tuple *area = NULL;
    size_t area_count = 0;
    if (bbc_tuples_find_area(scene, in.params.chains, &area, &area_count) != BBC_OK)
      cli_fail("%s: cannot list the candidate tuples (out of memory)", scene_path);
    bbc_tuple *all = realloc(cand, (count + area_count + 1) * sizeof *all);
    if (!all) cli_fail("out of memory");
    if (area_count) memcpy(all + count, area, area_count * sizeof *all);
    cand = all;
    count += area_count;
    free(area);
  }
  /* Stored tuples keep the candidates' order, so one pass pairs them up. */
  const bbc_tuple *stored = bbc_cache_tuples(c);
  int64_t *ids = malloc((count ? count : 1) * sizeof *ids);
  if (!ids) cli_fail("out of memory");
  uint32_t next = 0;
  for (size_t i = 0; i < count; i++) {
    ids[i] = -1;
    if (next < in.tuple_count && memcmp(&stored[next], &cand[i], sizeof *stored) == 0)
      ids[i] = next++;
  }
  if (next != in.tuple_count)
    cli_fail("%s: its tuples are not the candidates of %s (%u of %u matched)", cache_path,
             scene_path, next, in.tuple_count);

  size_t blocks = (count + CHECK_BLOCK - 1) / CHECK_BLOCK;
  /* Per block, per light kind and chain type (merged in block order: deterministic). */
  enum { KINDS = 4, SLOTS = KINDS * BBC_CHAIN_COUNT };
  bbc_validation *acc = calloc(SLOTS * (blocks ? blocks : 1), sizeof *acc);
  if (!acc) cli_fail("out of memory");
  cli_progress bar;
  cli_progress_begin(&bar, "checking", progress);
  size_t done = 0;
  bbc_result error = BBC_OK;
#pragma omp parallel
  {
    bbc_cache_cursor *cur = NULL;
    bbc_result r = bbc_cache_cursor_create(&cur, c);
#pragma omp for schedule(dynamic, 1)
    for (size_t b = 0; b < blocks; b++) {
      for (size_t i = b * CHECK_BLOCK; i < count && i < (b + 1) * CHECK_BLOCK && r == BBC_OK; i++) {
        const int kind = cand[i].light < scene->point_light_count
                             ? (int)scene->point_lights[cand[i].light].model.kind
                             : (int)BBC_LIGHT_AREA;
        r = bbc_validate_cached_tuple(
            c, cur, scene, &cand[i], ids[i], samples, 1,
            &acc[SLOTS * b + BBC_CHAIN_COUNT * (kind < KINDS ? kind : 0) + cand[i].chain]);
      }
#pragma omp atomic
      done++;
      if (omp_get_thread_num() == 0) {
        size_t d;
#pragma omp atomic read
        d = done;
        char detail[64];
        snprintf(detail, sizeof detail, "%zu/%zu tuples",
                 d * CHECK_BLOCK < count ? d * CHECK_BLOCK : count, count);
        cli_progress_update(&bar, (double)d / (double)blocks, detail);
      }
    }
    if (r != BBC_OK) {
#pragma omp critical
      if (error == BBC_OK) error = r;
    }
    bbc_cache_cursor_free(cur);
  }
  cli_progress_end(&bar);
  /* A damaged chunk was reported by the cache, in one line. */
  if (error == BBC_ERR_CHECKSUM || error == BBC_ERR_CORRUPT) exit(1);
  if (error != BBC_OK) cli_fail("%s: %s", cache_path, bbc_result_string(error));

  bbc_validation total[BBC_CHAIN_COUNT], by_kind[SLOTS];
  for (int k = 0; k < BBC_CHAIN_COUNT; k++) bbc_validation_reset(&total[k]);
  for (int k = 0; k < SLOTS; k++) bbc_validation_reset(&by_kind[k]);
  for (size_t b = 0; b < blocks; b++)
    for (int k = 0; k < SLOTS; k++) {
      bbc_validation_merge(&total[k % BBC_CHAIN_COUNT], &acc[SLOTS * b + k]);
      bbc_validation_merge(&by_kind[k], &acc[SLOTS * b + k]);
    }
  /* The chain types of the cache's parameters, and any other that holds tuples. */
  uint64_t failures = 0;
  for (int k = 0; k < BBC_CHAIN_COUNT; k++) {
    if (!(in.params.chains & BBC_CHAIN_BIT(k)) && total[k].tuples == 0) continue;
    const char *label = bbc_chain_name((bbc_chain)k);
    if (bbc_validation_print_summary(&total[k], label, stdout) != BBC_OK ||
        bbc_validation_print_histogram(&total[k], stdout) != BBC_OK)
      cli_fail("cannot write to stdout");
    failures += bbc_validation_failures(&total[k]);
  }
  /* With spot or directional lights, the summary per light kind as well. */
  int other_kinds = 0;
  for (int k = BBC_CHAIN_COUNT; k < SLOTS; k++) other_kinds |= by_kind[k].tuples > 0;
  static const char *const kind_names[KINDS] = {"point", "spot", "directional", "area"};
  for (int k = 0; k < SLOTS && other_kinds; k++) {
    if (by_kind[k].tuples == 0) continue;
    char label[64];
    snprintf(label, sizeof label, "%s, %s lights", bbc_chain_name((bbc_chain)(k % BBC_CHAIN_COUNT)),
             kind_names[k / BBC_CHAIN_COUNT]);
    if (bbc_validation_print_summary(&by_kind[k], label, stdout) != BBC_OK)
      cli_fail("cannot write to stdout");
  }
  for (int k = 0; k < BBC_CHAIN_COUNT; k++)
    if (bbc_validation_failures(&total[k])) {
      print_failure(bbc_chain_name((bbc_chain)k), &total[k].first_failure, stdout);
      break;
    }
  if (json) write_validation_json(json, total);
  if (failures)
    fprintf(stderr, "bbc-inspect: %s: %llu sampled paths break the bounds\n", cache_path,
            (unsigned long long)failures);
  free(acc);
  free(ids);
  free(cand);
  bbc_cache_close(c);
  bbc_scene_free(scene);
  return failures ? 1 : 0;
}

/* ------------------------------------------------------------------ solutions */

static uint64_t mix64(uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

/* Sample i of triangle t: barycentrics uniform in the triangle, a pure function of (t, i). */
static void sample_point(uint32_t t, uint32_t i, double b[2]) {
  uint64_t h = mix64(((uint64_t)t << 32) | i);
  double r1 = (double)(h >> 11) * 0x1p-53;
  double r2 = (double)(mix64(h) >> 11) * 0x1p-53;
  if (r1 + r2 > 1) r1 = 1 - r1, r2 = 1 - r2;
  b[0] = r1, b[1] = r2;
}

#define SOLUTION_BINS 5 /* 0, 1, 2, 3, 4+ */

static int cmd_solutions(cli_args *a, const char *scene_path, const char *cache_path) {
  const char *samples_text = NULL, *threads_text = NULL;
  bbc_light_units light_units = BBC_LIGHT_UNITS_FILE;
  while (a->i < a->argc) {
    const char *v;
    if (cli_option(a, "--samples", &v))
      samples_text = v;
    else if (cli_option(a, "--threads", &v))
      threads_text = v;
    else if (cli_option(a, "--light-units", &v))
      light_units = cli_parse_light_units(a, "--light-units", v);
    else
      cli_usage_error(usage, "unknown option '%s'", a->argv[a->i]);
  }
  uint32_t samples =
      samples_text ? (uint32_t)cli_parse_int(a, "--samples", samples_text, 1, UINT32_MAX) : 256;
  set_threads(a, threads_text);

  bbc_scene *scene = load_scene(scene_path, light_units);
  bbc_cache *c = open_cache_for(cache_path, scene);
  bbc_cache_info in;
  bbc_cache_get_info(c, &in);
  const bbc_grid *g = bbc_cache_grid(c);
  const bbc_tuple *tuples = bbc_cache_tuples(c);
  /* Receiver triangles in grid order; each is one unit of work. */
  uint64_t triangles = g->uv_triangle_count;
  uint32_t *tri = malloc((triangles ? triangles : 1) * sizeof *tri);
  if (!tri) cli_fail("out of memory");
  uint64_t n_tri = 0;
  for (uint32_t r = 0; r < g->receiver_count; r++)
    for (uint32_t k = 0; k < g->receivers[r].triangle_count; k++)
      tri[n_tri++] = g->receivers[r].first_triangle + k;

  uint64_t hist[SOLUTION_BINS] = {0}, above_m = 0, points = 0, solutions = 0;
  uint64_t h0 = 0, h1 = 0, h2 = 0, h3 = 0, h4 = 0;
  bbc_result error = BBC_OK;
#pragma omp parallel reduction(+ : h0, h1, h2, h3, h4, above_m, points, solutions)
  {
    bbc_cache_cursor *cur = NULL;
    bbc_result r = bbc_cache_cursor_create(&cur, c);
    bbc_solution sol[BBC_SOLVER_MAX_SOLUTIONS];
#pragma omp for schedule(dynamic, 4)
    for (uint64_t j = 0; j < n_tri; j++) {
      uint32_t t = tri[j];
      for (uint32_t i = 0; i < samples && r == BBC_OK; i++) {
        double b[2];
        sample_point(t, i, b);
        const bbc_cache_entry *e;
        uint32_t n;
        if ((r = bbc_cache_lookup(cur, t, b[0], b[1], &e, &n)) != BBC_OK) break;
        points++;
        for (uint32_t k = 0; k < n && r == BBC_OK; k++) {
          const bbc_tuple *u = &tuples[e[k].tuple];
          if (u->receiver != t || (u->chain != BBC_CHAIN_R && u->chain != BBC_CHAIN_T)) continue;
          bbc_path_geometry pg;
          if ((r = bbc_path_geometry_init(&pg, scene, u)) != BBC_OK) break;
          const bbc_vec3 *p = pg.receiver;
          double w0 = 1 - b[0] - b[1];
          bbc_vec3 xk = {w0 * p[0].x + b[0] * p[1].x + b[1] * p[2].x,
                         w0 * p[0].y + b[0] * p[1].y + b[1] * p[2].y,
                         w0 * p[0].z + b[0] * p[1].z + b[1] * p[2].z};
          size_t m = 0;
          if ((r = bbc_solver_single(&pg, xk, NULL, sol, BBC_SOLVER_MAX_SOLUTIONS, &m)) != BBC_OK)
            break;
          solutions += m;
          if (m == 0)
            h0++;
          else if (m == 1)
            h1++;
          else if (m == 2)
            h2++;
          else if (m == 3)
            h3++;
          else
            h4++;
          if ((double)m > in.params.m) above_m++;
        }
      }
    }
    if (r != BBC_OK) {
#pragma omp critical
      if (error == BBC_OK) error = r;
    }
    bbc_cache_cursor_free(cur);
  }
  /* A damaged chunk was reported by the cache, in one line. */
  if (error == BBC_ERR_CHECKSUM || error == BBC_ERR_CORRUPT) exit(1);
  if (error != BBC_OK) cli_fail("%s: %s", cache_path, bbc_result_string(error));
  hist[0] = h0, hist[1] = h1, hist[2] = h2, hist[3] = h3, hist[4] = h4;
  uint64_t pairs = h0 + h1 + h2 + h3 + h4;
  printf(
      "# %llu shading points on %llu receiver triangles (%u per triangle), %llu (point, "
      "tuple) pairs, %llu solutions\n",
      (unsigned long long)points, (unsigned long long)n_tri, samples, (unsigned long long)pairs,
      (unsigned long long)solutions);
  printf("# solutions  pairs  share\n");
  static const char *const names[SOLUTION_BINS] = {"0", "1", "2", "3", "4+"};
  for (int k = 0; k < SOLUTION_BINS; k++)
    printf("%-3s %12llu  %8.4f%%\n", names[k], (unsigned long long)hist[k],
           pairs ? 100.0 * (double)hist[k] / (double)pairs : 0.0);
  printf("more than m = %g: %llu of %llu pairs (%.4f%%)\n", in.params.m,
         (unsigned long long)above_m, (unsigned long long)pairs,
         pairs ? 100.0 * (double)above_m / (double)pairs : 0.0);
  free(tri);
  bbc_cache_close(c);
  bbc_scene_free(scene);
  return 0;
}

/* ------------------------------------------------------------------ diff */

static int differences;
static const char *diff_paths[2];

static void differ(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static void differ(const char *fmt, ...) {
  if (differences == 0) printf("--- %s\n+++ %s\n", diff_paths[0], diff_paths[1]);
  va_list ap;
  va_start(ap, fmt);
  vprintf(fmt, ap);
  va_end(ap);
  putchar('\n');
  differences++;
}

#define DIFF_U(name, a, b) \
  if ((a) != (b)) differ("%s: %llu | %llu", name, (unsigned long long)(a), (unsigned long long)(b))
#define DIFF_D(name, a, b) \
  if (memcmp(&(a), &(b), sizeof(double)) != 0) differ("%s: %.17g | %.17g", name, (a), (b))
#define DIFF_H(name, a, b) \
  if ((a) != (b))          \
  differ("%s: %016llx | %016llx", name, (unsigned long long)(a), (unsigned long long)(b))

static void print_tuple(char *buf, size_t size, const bbc_tuple *u) {
  char t2[16];
  if (u->specular[1] == BBC_NO_TRIANGLE)
    snprintf(t2, sizeof t2, "-");
  else
    snprintf(t2, sizeof t2, "%u", u->specular[1]);
  snprintf(buf, size, "%s light %u T1 %u T2 %s receiver %u",
           u->chain < BBC_CHAIN_COUNT ? bbc_chain_name((bbc_chain)u->chain) : "?", u->light,
           u->specular[0], t2, u->receiver);
}

static void print_list(const char *label, const bbc_cache_entry *e, uint32_t n) {
  printf("  %s: %u entries:", label, n);
  for (uint32_t i = 0; i < n; i++) printf(" %u:%.9g", e[i].tuple, (double)e[i].bound);
  putchar('\n');
}

static int cmd_diff(const char *path_a, const char *path_b) {
  bbc_cache *ca = open_cache(path_a), *cb = open_cache(path_b);
  bbc_cache_info a, b;
  bbc_cache_get_info(ca, &a);
  bbc_cache_get_info(cb, &b);
  diff_paths[0] = path_a, diff_paths[1] = path_b; /* the header of the first difference */
  DIFF_U("format version major", a.version_major, b.version_major);
  DIFF_U("format version minor", a.version_minor, b.version_minor);
  char ta[64], tb[64];
  if (a.params.chains != b.params.chains)
    differ("params.chains: %s | %s", chains_text(a.params.chains, ta, sizeof ta),
           chains_text(b.params.chains, tb, sizeof tb));
  DIFF_U("params.max_level", a.params.max_level, b.params.max_level);
  DIFF_D("params.sigma", a.params.sigma, b.params.sigma);
  DIFF_D("params.alpha_single", a.params.alpha_single, b.params.alpha_single);
  DIFF_D("params.alpha_double", a.params.alpha_double, b.params.alpha_double);
  DIFF_D("params.m", a.params.m, b.params.m);
  DIFF_U("params.grid_resolution", a.params.grid_resolution, b.params.grid_resolution);
  DIFF_U("params.remainder", a.params.remainder, b.params.remainder);
  DIFF_H("fingerprint.total", a.fingerprint.total, b.fingerprint.total);
  DIFF_H("fingerprint.geometry", a.fingerprint.geometry, b.fingerprint.geometry);
  DIFF_H("fingerprint.materials", a.fingerprint.materials, b.fingerprint.materials);
  DIFF_H("fingerprint.meshes", a.fingerprint.meshes, b.fingerprint.meshes);
  DIFF_H("fingerprint.lights", a.fingerprint.lights, b.fingerprint.lights);
  DIFF_H("fingerprint.params", a.fingerprint.params, b.fingerprint.params);
  DIFF_U("scene vertices", a.scene_vertex_count, b.scene_vertex_count);
  DIFF_U("scene triangles", a.scene_triangle_count, b.scene_triangle_count);
  DIFF_U("scene meshes", a.scene_mesh_count, b.scene_mesh_count);
  DIFF_U("scene materials", a.scene_material_count, b.scene_material_count);
  DIFF_U("scene point lights", a.scene_light_count, b.scene_light_count);

  /* Tuples: the count and the first tuple that differs. */
  DIFF_U("tuples", a.tuple_count, b.tuple_count);
  const bbc_tuple *tua = bbc_cache_tuples(ca), *tub = bbc_cache_tuples(cb);
  uint32_t common = a.tuple_count < b.tuple_count ? a.tuple_count : b.tuple_count;
  for (uint32_t i = 0; i < common; i++)
    if (memcmp(&tua[i], &tub[i], sizeof *tua) != 0) {
      char sa[128], sb[128];
      print_tuple(sa, sizeof sa, &tua[i]);
      print_tuple(sb, sizeof sb, &tub[i]);
      differ("first differing tuple %u: %s | %s", i, sa, sb);
      break;
    }

  /* Receivers and their grids. */
  const bbc_grid *ga = bbc_cache_grid(ca), *gb = bbc_cache_grid(cb);
  DIFF_U("receivers", ga->receiver_count, gb->receiver_count);
  int grids_equal = ga->receiver_count == gb->receiver_count && ga->cell_count == gb->cell_count &&
                    ga->uv_triangle_count == gb->uv_triangle_count;
  uint32_t rc = ga->receiver_count < gb->receiver_count ? ga->receiver_count : gb->receiver_count;
  for (uint32_t r = 0; r < rc; r++) {
    const bbc_receiver *x = &ga->receivers[r], *y = &gb->receivers[r];
    char name[64];
    int before = differences;
#define RFIELD(f)                                    \
  snprintf(name, sizeof name, "receiver %u " #f, r); \
  DIFF_U(name, x->f, y->f)
    RFIELD(mesh);
    RFIELD(parameterisation);
    RFIELD(first_triangle);
    RFIELD(triangle_count);
    RFIELD(width);
    RFIELD(height);
    RFIELD(first_cell);
#undef RFIELD
    for (int k = 0; k < 4; k++) {
      snprintf(name, sizeof name, "receiver %u domain[%d]", r, k);
      DIFF_D(name, x->domain[k], y->domain[k]);
    }
    for (int k = 0; k < 3; k++) {
      snprintf(name, sizeof name, "receiver %u axis_u[%d]", r, k);
      DIFF_D(name, x->axis_u[k], y->axis_u[k]);
      snprintf(name, sizeof name, "receiver %u axis_v[%d]", r, k);
      DIFF_D(name, x->axis_v[k], y->axis_v[k]);
    }
    if (differences == before && x->first_uv == y->first_uv &&
        memcmp(&ga->triangle_uv[6 * x->first_uv], &gb->triangle_uv[6 * y->first_uv],
               6 * sizeof(float) * x->triangle_count) != 0)
      differ("receiver %u: the grid coordinates of its triangles differ", r);
    if (differences != before) grids_equal = 0;
  }

  /* Cell lists, compared cell by cell when the grids agree. */
  if (!grids_equal) {
    differ("cells: %llu | %llu; the grids differ, so the cell lists are not compared",
           (unsigned long long)ga->cell_count, (unsigned long long)gb->cell_count);
  } else {
    bbc_cache_cursor *ka = NULL, *kb = NULL;
    if (bbc_cache_cursor_create(&ka, ca) != BBC_OK || bbc_cache_cursor_create(&kb, cb) != BBC_OK)
      cli_fail("out of memory");
    uint64_t differing = 0, first = 0;
    for (uint64_t cell = 0; cell < ga->cell_count; cell++) {
      const bbc_cache_entry *ea, *eb;
      uint32_t na, nb;
      if (bbc_cache_cell(ka, cell, &ea, &na) != BBC_OK) exit(1); /* the callback printed it */
      if (bbc_cache_cell(kb, cell, &eb, &nb) != BBC_OK) exit(1);
      int same = na == nb;
      for (uint32_t i = 0; same && i < na; i++)
        same = ea[i].tuple == eb[i].tuple && memcmp(&ea[i].bound, &eb[i].bound, sizeof(float)) == 0;
      if (!same && differing++ == 0) first = cell;
    }
    if (differing) {
      uint32_t r = 0;
      while (r + 1 < ga->receiver_count && ga->receivers[r + 1].first_cell <= first) r++;
      const bbc_receiver *rv = &ga->receivers[r];
      uint64_t local = first - rv->first_cell;
      differ("cell lists: %llu of %llu cells differ; first: receiver %u, cell %llu,%llu",
             (unsigned long long)differing, (unsigned long long)ga->cell_count, r,
             (unsigned long long)(local % rv->width), (unsigned long long)(local / rv->width));
      const bbc_cache_entry *ea, *eb;
      uint32_t na, nb;
      bbc_cache_cell(ka, first, &ea, &na);
      print_list("A", ea, na);
      bbc_cache_cell(kb, first, &eb, &nb);
      print_list("B", eb, nb);
    }
    bbc_cache_cursor_free(ka);
    bbc_cache_cursor_free(kb);
  }
  bbc_cache_close(ca);
  bbc_cache_close(cb);
  return differences ? 1 : 0;
}

/* ------------------------------------------------------------------ merge */

static int on_merge_progress(void *user, uint64_t done, uint64_t total) {
  cli_progress_update(user, total ? (double)done / (double)total : 1.0, "cells");
  return cli_interrupted;
}

static int cmd_merge(cli_args *a) {
  const char *out = NULL, *threads_text = NULL;
  const char **paths = calloc((size_t)a->argc, sizeof *paths);
  if (!paths) cli_fail("out of memory");
  size_t n = 0;
  int progress = -1;
  while (a->i < a->argc) {
    const char *v, *arg = a->argv[a->i];
    if (cli_option(a, "--threads", &v)) {
      threads_text = v;
    } else if (cli_flag(a, "--progress")) {
      progress = 1;
    } else if (cli_flag(a, "--no-progress")) {
      progress = 0;
    } else if (arg[0] == '-' && arg[1] != '\0') {
      cli_usage_error(usage, "unknown option '%s'", arg);
    } else {
      if (!out)
        out = arg;
      else
        paths[n++] = arg;
      a->i++;
    }
  }
  if (!out || n == 0) cli_usage_error(usage, "merge needs OUT.bbc and at least one SHARD.bbc");
  for (size_t i = 0; i < n; i++)
    if (strcmp(paths[i], out) == 0)
      cli_usage_error(usage, "merge: the output %s is also given as a shard", out);
  bbc_cache_merge_options options;
  memset(&options, 0, sizeof options);
  if (threads_text) options.threads = (int)cli_parse_int(a, "--threads", threads_text, 1, 4096);
  cli_catch_interrupts();

  bbc_cache **shards = calloc(n, sizeof *shards);
  if (!shards) cli_fail("out of memory");
  for (size_t i = 0; i < n; i++) shards[i] = open_cache(paths[i]); /* exits 1 on failure */
  cli_progress bar;
  cli_progress_begin(&bar, "merging", progress);
  options.error_fn = cli_print_message;
  options.progress_fn = on_merge_progress;
  options.progress_user = &bar;
  bbc_cache_builder *b = NULL;
  bbc_result r = bbc_cache_merge(&b, (const bbc_cache *const *)shards, n, &options);
  cli_progress_end(&bar);
  for (size_t i = 0; i < n; i++) bbc_cache_close(shards[i]);
  free(shards);
  free(paths);
  if (r == BBC_OK && !cli_interrupted) {
    bbc_cache_write_options wo;
    memset(&wo, 0, sizeof wo);
    wo.error_fn = cli_print_message;
    wo.progress_fn = cli_poll_interrupt;
    r = bbc_cache_builder_write(b, out, &wo);
  }
  bbc_cache_builder_free(b);
  if (r == BBC_ERR_CANCELLED || cli_interrupted) {
    fprintf(stderr, "bbc-inspect: interrupted; %s was not written\n", out);
    return 130;
  }
  return r == BBC_OK ? 0 : 1; /* the library printed the one line */
}

int main(int argc, char **argv) {
  cli_tool = "bbc-inspect";
  if (argc < 2) cli_usage_error(usage, "missing command");
  const char *cmd = argv[1];
  if (strcmp(cmd, "-h") == 0 || strcmp(cmd, "--help") == 0) {
    fputs(help, stdout);
    return 0;
  }
  if (strcmp(cmd, "--version") == 0) {
    printf("bbc-inspect %s (libbbc %s); reads .bbc format %d.x; merge writes %d.%d\n",
           bbc_version_string(), bbc_version_string(), BBC_FORMAT_VERSION_MAJOR,
           BBC_FORMAT_VERSION_MAJOR, BBC_FORMAT_VERSION_MINOR);
    return 0;
  }
  int known = strcmp(cmd, "info") == 0 || strcmp(cmd, "validate") == 0 ||
              strcmp(cmd, "dump") == 0 || strcmp(cmd, "heatmap") == 0 ||
              strcmp(cmd, "check-bounds") == 0 || strcmp(cmd, "solutions") == 0 ||
              strcmp(cmd, "diff") == 0 || strcmp(cmd, "merge") == 0;
  if (!known) cli_usage_error(usage, "unknown command '%s'", cmd);
  cli_args a = {argc, argv, 2, usage};
  /* Help after a command is still help. */
  for (int i = 2; i < argc; i++)
    if (strcmp(argv[i], "-h") == 0 || strcmp(argv[i], "--help") == 0) {
      fputs(help, stdout);
      return 0;
    }
  if (strcmp(cmd, "merge") == 0) return cmd_merge(&a);
  /* Commands of two files: SCENE CACHE or A B. */
  if (strcmp(cmd, "check-bounds") == 0 || strcmp(cmd, "solutions") == 0 ||
      strcmp(cmd, "diff") == 0) {
    int is_diff = strcmp(cmd, "diff") == 0;
    if (a.i + 1 >= argc || argv[a.i][0] == '-' || argv[a.i + 1][0] == '-')
      cli_usage_error(usage, "%s needs %s", cmd, is_diff ? "A.bbc B.bbc" : "SCENE.gltf CACHE.bbc");
    const char *first = argv[a.i++], *second = argv[a.i++];
    if (is_diff) {
      if (a.i < argc) cli_usage_error(usage, "unexpected argument '%s'", argv[a.i]);
      return cmd_diff(first, second);
    }
    return strcmp(cmd, "solutions") == 0 ? cmd_solutions(&a, first, second)
                                         : cmd_check_bounds(&a, first, second);
  }
  if (a.i >= argc || argv[a.i][0] == '-') cli_usage_error(usage, "%s needs a CACHE.bbc", cmd);
  const char *path = argv[a.i++];
  if (strcmp(cmd, "info") == 0 || strcmp(cmd, "validate") == 0) {
    if (a.i < argc) cli_usage_error(usage, "unexpected argument '%s'", argv[a.i]);
    return strcmp(cmd, "info") == 0 ? cmd_info(path) : cmd_validate(path);
  }
  if (strcmp(cmd, "dump") == 0) return cmd_dump(&a, path);
  return cmd_heatmap(&a, path);
}
