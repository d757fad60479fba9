/* bbc-inspect check-bounds: the cache against true paths (the paper's Fig. 17/18). */
#include <errno.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bbc/precompute.h"
#include "bbc/tuple.h"
#include "bbc/validate.h"
#include "inspect.h"

/* Tuples per block of check-bounds. Each block has its own accumulators, merged in block
 * order: the blocks do not depend on the thread count, so neither do the sums of
 * floating-point ratios (per-thread accumulators would make them depend on it). */
#define CHECK_BLOCK 16

static void print_failure(const char *label, const bbc_validation_failure *f, FILE *out) {
  static const char *const kinds[] = {"position", "upper", "lower", "discarded", "uncovered"};
  char receiver[24];
  fprintf(out,
          "%s: first failure: tuple (light %u, T1 %u, receiver %s), sample %u, u1 (%.9g, %.9g), "
          "uk (%.9g, %.9g), irradiance %.9g, kinds",
          label, f->tuple.light, f->tuple.specular[0],
          inspect_receiver_text(f->tuple.receiver, receiver, sizeof receiver), f->sample, f->u1[0],
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

int cmd_check_bounds(cli_args *a, const char *scene_path, const char *cache_path) {
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
      cli_usage_error(a->usage, "unknown option '%s'", a->argv[a->i]);
  }
  uint32_t samples =
      samples_text ? (uint32_t)cli_parse_int(a, "--samples", samples_text, 1, UINT32_MAX) : 100;
  inspect_set_threads(a, threads_text);

  bbc_scene *scene = inspect_load_scene(scene_path, light_units);
  bbc_cache *c = inspect_open_cache_for(cache_path, scene);
  bbc_cache_info in;
  bbc_cache_get_info(c, &in);
  bbc_tuple *cand = NULL;
  size_t count = 0;
  /* Beam receivers: the search gives both kinds of light at once. */
  const uint32_t beam_area_chains =
      !in.params.area_lights ? 0
      : in.params.area_double
          ? in.params.chains
          : in.params.chains & (BBC_CHAIN_BIT(BBC_CHAIN_R) | BBC_CHAIN_BIT(BBC_CHAIN_T));
  if ((in.params.beam_receivers
           ? bbc_tuples_find_beam(scene, in.params.chains, beam_area_chains, &cand, &count)
           : bbc_tuples_find(scene, in.params.chains, &cand, &count)) != BBC_OK)
    cli_fail("%s: cannot list the candidate tuples (out of memory)", scene_path);
  if (in.params.area_lights && !in.params.beam_receivers) {
    /* The area lights' candidates follow the punctual lights' (bbc_precompute). */
    bbc_tuple *area = NULL;
    size_t area_count = 0;
    /* Before format 1.4 (PARM flags bit 2) the emitters had R and T tuples only. */
    const uint32_t area_chains =
        in.params.area_double ? in.params.chains
                              : in.params.chains & (BBC_CHAIN_BIT(BBC_CHAIN_R) | BBC_CHAIN_BIT(BBC_CHAIN_T));
    if (area_chains && bbc_tuples_find_area(scene, area_chains, &area, &area_count) != BBC_OK)
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
