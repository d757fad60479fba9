/* Helpers shared by the command-line tools (not part of libbbc): strict argument
 * parsing in the STYLE.md conventions, error reporting and a progress bar. */
#ifndef BBC_CLI_H
#define BBC_CLI_H

#include <signal.h>
#include <stdint.h>
#include <stdio.h>

#include "bbc/common.h"
#include "bbc/scene.h"

/* The tool's name, used as the prefix of every message. */
extern const char *cli_tool;

/* Prints "tool: <message>" and the short usage to stderr, then exits with status 2. */
_Noreturn void cli_usage_error(const char *usage, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));
/* Prints "tool: <message>" to stderr and exits with status 1. */
_Noreturn void cli_fail(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* A message callback for libbbc that prints "tool: <message>" to stderr. */
void cli_print_message(void *user, bbc_result code, const char *message);
/* The same, but only for the first message of the process: a cache's error callback,
 * since the first damaged chunk ends every tool (threads may meet several at once). */
void cli_print_first_message(void *user, bbc_result code, const char *message);
/* The same for warnings: "tool: warning: <message>". */
void cli_print_warning(void *user, bbc_result code, const char *message);

struct bbc_cache;
/* bbc_cache_match_scene: 0 when the cache was computed for the scene, after a note on
 * stderr when the scene differed by float noise and now holds the cache's geometry;
 * -1 after the cache's one-line error otherwise. */
int cli_match_scene(const struct bbc_cache *cache, const char *cache_path, bbc_scene *scene);

/* Argument cursor: matches "--name value" and "--name=value". */
typedef struct cli_args {
  int argc;
  char **argv;
  int i;
  const char *usage;
} cli_args;

/* 1 if argv[i] is the flag (no value), advancing past it. */
int cli_flag(cli_args *a, const char *name);
/* 1 if argv[i] is the option; *value receives its value (a missing value is a usage
 * error). */
int cli_option(cli_args *a, const char *name, const char **value);

/* Strict number parsing: the whole string must be a number in [lo, hi]; otherwise a
 * usage error naming the option. */
double cli_parse_double(const cli_args *a, const char *name, const char *text, double lo,
                        double hi);
long long cli_parse_int(const cli_args *a, const char *name, const char *text, long long lo,
                        long long hi);

/* A chain-type list such as "R,T" as a BBC_CHAIN_BIT mask; a usage error naming the
 * option for an unknown type or an empty list. */
uint32_t cli_parse_chains(const cli_args *a, const char *name, const char *text);

/* --light-units photometric|radiometric as a bbc_light_units (scene.h); a usage error
 * for anything else. */
bbc_light_units cli_parse_light_units(const cli_args *a, const char *name, const char *text);

/* --shard I/N, auto or auto/N as the shard index and count (0 <= index < count):
 *   I/N      two decimal integers, 0 <= I < N < 2^32;
 *   auto     the index from the scheduler: SLURM_ARRAY_TASK_ID (a Slurm array, numbered
 *            from 0) or JOB_COMPLETION_INDEX (a Kubernetes Indexed Job); the count from
 *            BBC_SHARD_COUNT, else, for Slurm, from SLURM_ARRAY_TASK_COUNT, provided the
 *            array is the whole 0..COUNT-1 (SLURM_ARRAY_TASK_MIN, _MAX) and more than one
 *            task (a task resubmitted alone sees a count of 1);
 *   auto/N   the same with the count N (BBC_SHARD_COUNT, when set, must agree).
 * Bad syntax is a usage error (exit 2); a missing or inconsistent environment variable
 * ends the tool with one line naming it (exit 1). */
void cli_parse_shard(const cli_args *a, const char *text, uint32_t *index, uint32_t *count);

/* Removes the temporary files an atomic write of `path` leaves when its process is
 * killed before it can clean up (SIGKILL, a lost node): "<path>.tmp.<pid>", and
 * "<path>.tmp.<pid>.tmp.<pid>", unless <pid> is a process that still runs on this
 * machine. Says so on stderr for each; returns how many it removed. */
int cli_remove_leftovers(const char *path);

/* Set once SIGINT or SIGTERM arrived, after cli_catch_interrupts. Long operations poll
 * it (through their progress callbacks) and stop; the tool then exits with 130. */
extern volatile int cli_interrupted;
void cli_catch_interrupts(void);
/* A progress callback (bbc_progress_fn) that shows nothing and cancels on an interrupt. */
int cli_poll_interrupt(void *user, uint64_t done, uint64_t total);
/* A cancel callback (bbc_precompute_options.cancel_fn): non-zero after an interrupt. */
int cli_interrupt_requested(void *user);

/* A progress bar on stderr: shown only when enabled, redrawn at most five times a
 * second, with percent, elapsed time and ETA. */
typedef struct cli_progress {
  int enabled;
  const char *label;
  double start, last_draw;
  int drawn;
} cli_progress;

/* enabled: 1 on, 0 off, -1 when stderr is a terminal. */
void cli_progress_begin(cli_progress *p, const char *label, int enabled);
/* fraction in [0, 1]; detail is an optional short text such as "12/64 spp". */
void cli_progress_update(cli_progress *p, double fraction, const char *detail);
void cli_progress_end(cli_progress *p);

double cli_now(void);

/* Prints one line per light that has tuples, indented by `indent`: "light 0 (directional):
 * 13 tuples (R 13)". scene may be NULL (the kind is then not named). */
struct bbc_tuple;
struct bbc_scene;
void cli_print_tuples_per_light(FILE *out, const char *indent, const struct bbc_tuple *tuples,
                                uint32_t count, uint32_t light_count,
                                const struct bbc_scene *scene);

#endif
