#define _POSIX_C_SOURCE 200809L
#include "cli.h"

#include "bbc/cache.h"

#include "bbc/scene.h"
#include "bbc/tuple.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

const char *cli_tool = "bbc";

void cli_usage_error(const char *usage, const char *fmt, ...) {
  va_list ap;
  fprintf(stderr, "%s: ", cli_tool);
  va_start(ap, fmt);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fprintf(stderr, "\n%s", usage);
  exit(2);
}

void cli_fail(const char *fmt, ...) {
  va_list ap;
  fprintf(stderr, "%s: ", cli_tool);
  va_start(ap, fmt);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fputc('\n', stderr);
  exit(1);
}

void cli_print_message(void *user, bbc_result code, const char *message) {
  (void)user;
  (void)code;
  fprintf(stderr, "%s: %s\n", cli_tool, message);
}

void cli_print_first_message(void *user, bbc_result code, const char *message) {
  static atomic_flag said = ATOMIC_FLAG_INIT;
  if (!atomic_flag_test_and_set(&said)) cli_print_message(user, code, message);
}

void cli_print_warning(void *user, bbc_result code, const char *message) {
  (void)user;
  (void)code;
  fprintf(stderr, "%s: warning: %s\n", cli_tool, message);
}

int cli_match_scene(const bbc_cache *cache, const char *cache_path, bbc_scene *scene) {
  bbc_scene_match m;
  if (bbc_cache_match_scene(cache, scene, &m) != BBC_OK) return -1;
  if (m.adopted)
    fprintf(stderr,
            "%s: note: %s differs from the scene of %s by float noise only (%u triangles "
            "reordered; coordinates off by up to %.3g, normals %.3g, uvs %.3g): using the "
            "cache's geometry\n",
            cli_tool, scene->path, cache_path, m.triangles_moved, m.position_error,
            m.normal_error, m.uv_error);
  return 0;
}

int cli_flag(cli_args *a, const char *name) {
  if (strcmp(a->argv[a->i], name) != 0) return 0;
  a->i++;
  return 1;
}

int cli_option(cli_args *a, const char *name, const char **value) {
  const char *arg = a->argv[a->i];
  size_t n = strlen(name);
  if (strncmp(arg, name, n) != 0) return 0;
  if (arg[n] == '=') {
    *value = arg + n + 1;
    a->i++;
    return 1;
  }
  if (arg[n] != '\0') return 0;
  if (a->i + 1 >= a->argc) cli_usage_error(a->usage, "%s needs a value", name);
  *value = a->argv[a->i + 1];
  a->i += 2;
  return 1;
}

double cli_parse_double(const cli_args *a, const char *name, const char *text, double lo,
                        double hi) {
  char *end = NULL;
  errno = 0;
  double v = strtod(text, &end);
  if (end == text || *end != '\0' || errno == ERANGE || !isfinite(v))
    cli_usage_error(a->usage, "%s: '%s' is not a number", name, text);
  if (v < lo || v > hi)
    cli_usage_error(a->usage, "%s: %s is out of range [%g, %g]", name, text, lo, hi);
  return v;
}

long long cli_parse_int(const cli_args *a, const char *name, const char *text, long long lo,
                        long long hi) {
  char *end = NULL;
  errno = 0;
  long long v = strtoll(text, &end, 10);
  if (end == text || *end != '\0' || errno == ERANGE)
    cli_usage_error(a->usage, "%s: '%s' is not an integer", name, text);
  if (v < lo || v > hi)
    cli_usage_error(a->usage, "%s: %s is out of range [%lld, %lld]", name, text, lo, hi);
  return v;
}

uint32_t cli_parse_chains(const cli_args *a, const char *name, const char *text) {
  uint32_t mask = 0;
  char buffer[256];
  snprintf(buffer, sizeof buffer, "%s", text);
  for (char *save = NULL, *chain_name = strtok_r(buffer, ",", &save); chain_name;
       chain_name = strtok_r(NULL, ",", &save)) {
    bbc_chain chain;
    if (!bbc_chain_parse(chain_name, &chain))
      cli_usage_error(a->usage, "%s: unknown chain type '%s' (R, T, RR, RT, TR, TT)", name,
                      chain_name);
    mask |= 1u << chain;
  }
  if (!mask) cli_usage_error(a->usage, "%s: no chain type given", name);
  return mask;
}

bbc_light_units cli_parse_light_units(const cli_args *a, const char *name, const char *text) {
  if (strcmp(text, "photometric") == 0) return BBC_LIGHT_UNITS_PHOTOMETRIC;
  if (strcmp(text, "radiometric") == 0) return BBC_LIGHT_UNITS_RADIOMETRIC;
  cli_usage_error(a->usage, "%s: unknown units '%s' (photometric, radiometric)", name, text);
}

volatile int cli_interrupted = 0;

static void on_interrupt(int sig) {
  (void)sig;
  cli_interrupted = 1;
}

void cli_catch_interrupts(void) {
  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_interrupt;
  sigaction(SIGINT, &sa, NULL);
  sigaction(SIGTERM, &sa, NULL);
}

int cli_interrupt_requested(void *user) {
  (void)user;
  return cli_interrupted;
}

int cli_poll_interrupt(void *user, uint64_t done, uint64_t total) {
  (void)user;
  (void)done;
  (void)total;
  return cli_interrupted;
}

double cli_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void format_duration(char *out, size_t size, double seconds) {
  if (!(seconds >= 0) || seconds > 1e7) {
    snprintf(out, size, "--:--");
    return;
  }
  long s = (long)(seconds + 0.5);
  if (s >= 3600)
    snprintf(out, size, "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  else
    snprintf(out, size, "%02ld:%02ld", s / 60, s % 60);
}

void cli_progress_begin(cli_progress *p, const char *label, int enabled) {
  p->enabled = enabled < 0 ? isatty(STDERR_FILENO) : enabled;
  p->label = label;
  p->start = cli_now();
  p->last_draw = -1.0;
  p->drawn = 0;
}

void cli_progress_update(cli_progress *p, double fraction, const char *detail) {
  if (!p->enabled) return;
  double now = cli_now();
  if (fraction < 1.0 && p->last_draw >= 0 && now - p->last_draw < 0.2) return;
  p->last_draw = now;
  if (fraction < 0) fraction = 0;
  if (fraction > 1) fraction = 1;
  double elapsed = now - p->start;
  char el[32], eta[32];
  format_duration(el, sizeof el, elapsed);
  format_duration(eta, sizeof eta, fraction > 0 ? elapsed * (1.0 - fraction) / fraction : -1);
  enum { WIDTH = 30 };
  char bar[WIDTH + 1];
  int filled = (int)(fraction * WIDTH);
  for (int i = 0; i < WIDTH; i++) bar[i] = i < filled ? '#' : '.';
  bar[WIDTH] = '\0';
  fprintf(stderr, "\r%s [%s] %3d%%  %s elapsed, ETA %s  %s\033[K", p->label, bar,
          (int)(fraction * 100.0), el, eta, detail ? detail : "");
  fflush(stderr);
  p->drawn = 1;
}

void cli_progress_end(cli_progress *p) {
  if (p->enabled && p->drawn) fputc('\n', stderr);
  p->drawn = 0;
}

void cli_print_tuples_per_light(FILE *out, const char *indent, const bbc_tuple *tuples,
                                uint32_t count, uint32_t light_count, const bbc_scene *scene) {
  static const char *const kinds[3] = {"point", "spot", "directional"};
  for (uint32_t l = 0; l < light_count; l++) {
    uint64_t per_chain[BBC_CHAIN_COUNT] = {0}, total = 0;
    for (uint32_t i = 0; i < count; i++)
      if (tuples[i].light == l && tuples[i].chain < BBC_CHAIN_COUNT) per_chain[tuples[i].chain]++, total++;
    if (!total) continue;
    fprintf(out, "%slight %u", indent, l);
    if (scene && l < scene->point_light_count && (unsigned)scene->point_lights[l].model.kind < 3)
      fprintf(out, " (%s)", kinds[scene->point_lights[l].model.kind]);
    else if (scene && bbc_scene_light_emitter(scene, l) >= 0)
      fprintf(out, " (area, triangle %u)", scene->emitters[bbc_scene_light_emitter(scene, l)]);
    fprintf(out, ": %llu tuples", (unsigned long long)total);
    int listed = 0;
    for (int k = 0; k < BBC_CHAIN_COUNT; k++)
      if (per_chain[k])
        fprintf(out, "%s%s %llu", listed++ ? ", " : " (", bbc_chain_name((bbc_chain)k),
                (unsigned long long)per_chain[k]);
    fprintf(out, "%s\n", listed ? ")" : "");
  }
}
