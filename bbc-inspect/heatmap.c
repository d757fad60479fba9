/* bbc-inspect heatmap: per receiver, the sum of each cell's bounds as an EXR image. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/image.h"
#include "inspect.h"

/* OUT.exr -> OUT.<r>.exr (or OUT.<r> without an .exr ending). */
static void receiver_path(const char *out, uint32_t r, char *buf, size_t size) {
  size_t n = strlen(out);
  if (n > 4 && strcmp(out + n - 4, ".exr") == 0)
    snprintf(buf, size, "%.*s.%u.exr", (int)(n - 4), out, r);
  else
    snprintf(buf, size, "%s.%u", out, r);
}

int cmd_heatmap(cli_args *a, const char *path) {
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
      cli_usage_error(a->usage, "unknown option '%s'", a->argv[a->i]);
  }
  if (!out) cli_usage_error(a->usage, "heatmap needs -o OUT.exr");
  bbc_cache *c = inspect_open_cache(path);
  const bbc_grid *g = bbc_cache_grid(c);
  uint32_t first = 0, last = g->receiver_count - 1;
  if (receiver_text) first = last = inspect_parse_receiver(a, receiver_text, g);
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
        if (bbc_cache_leaf(cur, (bbc_cell){r, x, y}, &e, &n) != BBC_OK) exit(1);
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
