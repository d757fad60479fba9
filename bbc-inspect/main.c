/* bbc-inspect: shows, validates and draws .bbc caches (format-spec/bbc-format.md).
 * In the manner of OpenEXR's exrinfo: one subcommand per question, data on stdout,
 * diagnostics on stderr, exit 1 for a bad file and 2 for bad usage. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/cache.h"
#include "bbc/common.h"
#include "bbc/grid.h"
#include "bbc/image.h"
#include "bbc/tuple.h"
#include "cli.h"

static const char usage[] =
    "usage: bbc-inspect info CACHE.bbc\n"
    "       bbc-inspect validate CACHE.bbc\n"
    "       bbc-inspect dump CACHE.bbc --cell X,Y [--receiver R]\n"
    "       bbc-inspect heatmap CACHE.bbc -o OUT.exr [--receiver R] [--log10]\n"
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
    "\n"
    "Options:\n"
    "  -h, --help           this text\n"
    "  --version            the versions of bbc-inspect, libbbc and the .bbc format\n"
    "\n"
    "Exit status: 0 success, 1 a file could not be read or is invalid, 2 bad usage.\n";

static bbc_cache *open_cache(const char *path) {
  bbc_cache_options o = {cli_print_message, NULL};
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
  printf("scene        %u vertices, %u triangles, %u meshes, %u materials, %u point lights\n",
         in.scene_vertex_count, in.scene_triangle_count, in.scene_mesh_count,
         in.scene_material_count, in.scene_light_count);
  uint64_t per_chain[BBC_CHAIN_COUNT] = {0};
  const bbc_tuple *t = bbc_cache_tuples(c);
  for (uint32_t i = 0; i < in.tuple_count; i++) per_chain[t[i].chain]++;
  printf("tuples       %u", in.tuple_count);
  int listed = 0;
  for (int k = 0; k < BBC_CHAIN_COUNT; k++)
    if (per_chain[k])
      printf("%s%s %llu", listed++ ? ", " : " (", bbc_chain_name((bbc_chain)k),
             (unsigned long long)per_chain[k]);
  printf("%s\n", listed ? ")" : "");
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
  printf("%s: valid (format %u.%u, %u tuples, %u receivers, %u chunks, %llu entries)\n", path,
         in.version_major, in.version_minor, in.tuple_count, in.receiver_count, in.chunk_count,
         (unsigned long long)in.entry_count);
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

int main(int argc, char **argv) {
  cli_tool = "bbc-inspect";
  if (argc < 2) cli_usage_error(usage, "missing command");
  const char *cmd = argv[1];
  if (strcmp(cmd, "-h") == 0 || strcmp(cmd, "--help") == 0) {
    fputs(help, stdout);
    return 0;
  }
  if (strcmp(cmd, "--version") == 0) {
    printf(
        "bbc-inspect %s (libbbc %s); reads .bbc format %d.x (writes none; libbbc writes "
        "%d.%d)\n",
        bbc_version_string(), bbc_version_string(), BBC_FORMAT_VERSION_MAJOR,
        BBC_FORMAT_VERSION_MAJOR, BBC_FORMAT_VERSION_MINOR);
    return 0;
  }
  int known = strcmp(cmd, "info") == 0 || strcmp(cmd, "validate") == 0 ||
              strcmp(cmd, "dump") == 0 || strcmp(cmd, "heatmap") == 0;
  if (!known) cli_usage_error(usage, "unknown command '%s'", cmd);
  cli_args a = {argc, argv, 2, usage};
  /* Help after a command is still help. */
  for (int i = 2; i < argc; i++)
    if (strcmp(argv[i], "-h") == 0 || strcmp(argv[i], "--help") == 0) {
      fputs(help, stdout);
      return 0;
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
