/* bbc-inspect dump: one cell's list. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/tuple.h"
#include "inspect.h"

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

int cmd_dump(cli_args *a, const char *path) {
  const char *cell_text = NULL, *receiver_text = NULL;
  while (a->i < a->argc) {
    const char *v;
    if (cli_option(a, "--cell", &v))
      cell_text = v;
    else if (cli_option(a, "--receiver", &v))
      receiver_text = v;
    else
      cli_usage_error(a->usage, "unknown option '%s'", a->argv[a->i]);
  }
  if (!cell_text) cli_usage_error(a->usage, "dump needs --cell X,Y");
  long long x, y;
  parse_cell(a, cell_text, &x, &y);
  bbc_cache *c = inspect_open_cache(path);
  const bbc_grid *g = bbc_cache_grid(c);
  uint32_t r = receiver_text ? inspect_parse_receiver(a, receiver_text, g) : 0;
  const bbc_receiver *rc = &g->receivers[r];
  if (x >= rc->width || y >= rc->height)
    cli_usage_error(a->usage, "--cell: %lld,%lld is outside the %u x %u grid of receiver %u", x, y,
                    rc->width, rc->height, r);
  bbc_cache_cursor *cur = NULL;
  if (bbc_cache_cursor_create(&cur, c) != BBC_OK) cli_fail("out of memory");
  const bbc_cache_entry *e;
  uint32_t n;
  /* What a point of the cell sees: with levels, the coarser cells' lists too. */
  if (bbc_cache_leaf(cur, (bbc_cell){r, (uint32_t)x, (uint32_t)y}, &e, &n) != BBC_OK)
    exit(1); /* the callback printed it */
  const bbc_tuple *t = bbc_cache_tuples(c);
  printf("# receiver %u, cell %lld,%lld: %u entries\n", r, x, y, n);
  printf("# tuple chain light T1 T2 receiver bound\n");
  for (uint32_t i = 0; i < n; i++) {
    const bbc_tuple *u = &t[e[i].tuple];
    char t2[16], receiver[24];
    if (u->specular[1] == BBC_NO_TRIANGLE)
      snprintf(t2, sizeof t2, "-");
    else
      snprintf(t2, sizeof t2, "%u", u->specular[1]);
    printf("%u %s %u %u %s %s %.9g\n", e[i].tuple, bbc_chain_name((bbc_chain)u->chain), u->light,
           u->specular[0], t2, inspect_receiver_text(u->receiver, receiver, sizeof receiver),
           (double)e[i].bound);
  }
  bbc_cache_cursor_free(cur);
  bbc_cache_close(c);
  return 0;
}
