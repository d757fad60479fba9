/* bbc-inspect: what its subcommands share, and the subcommands themselves (one file
 * each). Each returns the tool's exit status; bad usage and unreadable files exit from
 * within, with one line on stderr (cli.h). */
#ifndef BBC_INSPECT_H
#define BBC_INSPECT_H

#include <stdint.h>
#include <stdlib.h>

#include "bbc/cache.h"
#include "bbc/grid.h"
#include "bbc/scene.h"
#include "cli.h"

/* Opens the cache; exits 1 (the library printed the line) when it cannot be read. */
bbc_cache *inspect_open_cache(const char *path);
/* The same, and refuses a cache of another scene. */
bbc_cache *inspect_open_cache_for(const char *path, bbc_scene *scene);
/* Loads the scene; exits 1 when it cannot be read. */
bbc_scene *inspect_load_scene(const char *path, bbc_light_units light_units);
/* A chain-type mask as "R,T". */
const char *inspect_chains_text(uint32_t mask, char *out, size_t size);
/* 1 if the file starts as a .bbc cache does (to tell swapped arguments apart). */
int inspect_is_cache(const char *path);
/* --threads N, when given. */
void inspect_set_threads(const cli_args *a, const char *text);
/* A tuple's receiver field as text: the triangle's index, or "plane:M" for the plane
 * of receiver mesh M. */
const char *inspect_receiver_text(uint32_t receiver, char *out, size_t size);
/* --receiver R of the cache's grid. */
uint32_t inspect_parse_receiver(const cli_args *a, const char *text, const bbc_grid *g);

int cmd_info(const char *path);
int cmd_validate(const char *path);
int cmd_dump(cli_args *a, const char *path);
int cmd_heatmap(cli_args *a, const char *path);
int cmd_check_bounds(cli_args *a, const char *scene_path, const char *cache_path);
int cmd_solutions(cli_args *a, const char *scene_path, const char *cache_path);
int cmd_diff(const char *path_a, const char *path_b);
int cmd_merge(cli_args *a);

#endif
