/* What the subcommands of bbc-inspect share: opening a cache (and refusing one of
 * another scene), loading a scene, --threads and --receiver. */
#include <omp.h>
#include <stdio.h>
#include <string.h>

#include "inspect.h"
#include "bbc/tuple.h"

bbc_cache *inspect_open_cache(const char *path) {
  bbc_cache_options o = {cli_print_first_message, NULL, 0};
  bbc_cache *c = NULL;
  if (bbc_cache_open(&c, path, &o) != BBC_OK) exit(1); /* the callback printed the line */
  return c;
}

const char *inspect_chains_text(uint32_t mask, char *out, size_t size) {
  out[0] = '\0';
  for (int c = 0; c < BBC_CHAIN_COUNT; c++)
    if (mask & BBC_CHAIN_BIT(c)) {
      size_t n = strlen(out);
      snprintf(out + n, size - n, "%s%s", n ? "," : "", bbc_chain_name((bbc_chain)c));
    }
  return out;
}

uint32_t inspect_parse_receiver(const cli_args *a, const char *text, const bbc_grid *g) {
  long long r = cli_parse_int(a, "--receiver", text, 0, UINT32_MAX);
  if ((uint64_t)r >= g->receiver_count)
    cli_usage_error(a->usage, "--receiver: %lld, the cache has %u receivers", r, g->receiver_count);
  return (uint32_t)r;
}

bbc_scene *inspect_load_scene(const char *path, bbc_light_units light_units) {
  bbc_scene_options o = {cli_print_message, cli_print_warning, NULL, light_units};
  bbc_scene *s = NULL;
  if (bbc_scene_load(&s, path, &o) != BBC_OK) exit(1); /* the callback printed the line */
  return s;
}

/* Opens the cache and refuses one of another scene (one line from the callback). */
bbc_cache *inspect_open_cache_for(const char *path, bbc_scene *scene) {
  bbc_cache *c = inspect_open_cache(path);
  if (cli_match_scene(c, path, scene) != 0) exit(1);
  return c;
}

void inspect_set_threads(const cli_args *a, const char *text) {
  if (text) omp_set_num_threads((int)cli_parse_int(a, "--threads", text, 1, 4096));
}

int inspect_is_cache(const char *path) {
  static const unsigned char magic[4] = {0x89, 'B', 'B', 'C'};
  unsigned char head[4];
  FILE *f = fopen(path, "rb");
  if (!f) return 0;
  size_t n = fread(head, 1, sizeof head, f);
  fclose(f);
  return n == sizeof head && memcmp(head, magic, sizeof head) == 0;
}

const char *inspect_receiver_text(uint32_t receiver, char *out, size_t size) {
  if (bbc_receiver_is_beam(receiver))
    snprintf(out, size, "beam");
  else if (bbc_receiver_is_plane(receiver))
    snprintf(out, size, "plane:%u", bbc_receiver_plane_mesh(receiver));
  else
    snprintf(out, size, "%u", receiver);
  return out;
}
