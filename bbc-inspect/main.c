/* bbc-inspect: shows, validates and draws .bbc caches (format-spec/bbc-format.md).
 * In the manner of OpenEXR's exrinfo: one subcommand per question (one file each, see
 * inspect.h), data on stdout, diagnostics on stderr, exit 1 for a bad file and 2 for bad
 * usage. */
#include <stdio.h>
#include <string.h>

#include "inspect.h"

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
    "  dump CACHE.bbc       prints the list a point of one cell sees (with levels of\n"
    "                       cells, its coarser cells' too): tuple id, chain, light, specular\n"
    "                       triangles T1 T2, receiver (a triangle, or plane:M for the\n"
    "                       plane of receiver mesh M) and irradiance bound\n"
    "      --cell X,Y         the cell (column X, row Y of the receiver's grid); required\n"
    "      --receiver R       the receiver (default 0)\n"
    "  heatmap CACHE.bbc    writes, per receiver, the sum of the bounds a point of each cell\n"
    "                       sees (with its coarser levels' cells) as a grey EXR image\n"
    "                       (image row y is grid row y)\n"
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
    "                       one-bounce tuple of its cell that ends on that triangle or its\n"
    "                       plane; prints\n"
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
    if (!is_diff && inspect_is_cache(first) && !inspect_is_cache(second))
      cli_usage_error(usage, "%s needs SCENE.gltf CACHE.bbc: %s is a cache (swapped?)", cmd,
                      first);
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
