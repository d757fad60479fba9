/* --shard I/N, --shard auto and --shard auto/N (cli.h), and the removal of the temporary
 * files a killed run left beside an output. */
#define _POSIX_C_SOURCE 200809L
#include "cli.h"

#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <unistd.h>

/* A decimal integer of 1 to 10 digits, nothing else, below 2^32: 0 and *value, else -1. */
static int parse_u32(const char *text, uint32_t *value) {
  unsigned long long v = 0;
  const char *p = text;
  if (*p < '0' || *p > '9') return -1;
  for (; *p >= '0' && *p <= '9'; p++) {
    v = v * 10 + (unsigned)(*p - '0');
    if (v > UINT32_MAX) return -1;
  }
  if (*p != '\0') return -1;
  *value = (uint32_t)v;
  return 0;
}

/* The environment variable `name` as a number; -1 when it is not set. A value that is
 * set but not a number ends the tool with one line. */
static int env_u32(const char *name, uint32_t *value) {
  const char *text = getenv(name);
  if (!text) return -1;
  if (parse_u32(text, value) != 0)
    cli_fail("--shard auto: %s is '%s', not a whole number below 2^32", name, text);
  return 0;
}

/* --shard auto[/N]: the index from the scheduler's environment, the count from N, else
 * BBC_SHARD_COUNT, else (Slurm only) the array's own size. Every inconsistency ends the
 * tool with one line, exit 1: the command line is right, its environment is not. */
static void shard_from_environment(const cli_args *a, const char *text, uint32_t *index,
                                   uint32_t *count) {
  uint32_t n = 0, env_n = 0;
  int have_n = 0;
  if (text[4] == '/') {
    if (parse_u32(text + 5, &n) != 0 || n == 0)
      cli_usage_error(a->usage, "--shard: '%s' is not auto/N with a count N >= 1", text);
    have_n = 1;
  } else if (text[4] != '\0') {
    cli_usage_error(a->usage, "--shard: '%s' is neither I/N, auto nor auto/N", text);
  }
  if (env_u32("BBC_SHARD_COUNT", &env_n) == 0) {
    if (env_n == 0) cli_fail("--shard auto: BBC_SHARD_COUNT is 0; the shard count is at least 1");
    if (have_n && env_n != n) cli_fail("--shard %s: BBC_SHARD_COUNT is %u, not %u", text, env_n, n);
    n = env_n;
    have_n = 1;
  }

  uint32_t slurm_id = 0, k8s_id = 0;
  int slurm = env_u32("SLURM_ARRAY_TASK_ID", &slurm_id) == 0;
  int k8s = env_u32("JOB_COMPLETION_INDEX", &k8s_id) == 0;
  if (slurm && k8s)
    cli_fail(
        "--shard auto: both SLURM_ARRAY_TASK_ID (%u) and JOB_COMPLETION_INDEX (%u) are "
        "set; unset the one that is not the scheduler's",
        slurm_id, k8s_id);
  if (!slurm && !k8s) {
    if (getenv("SLURM_JOB_ID"))
      cli_fail(
          "--shard auto: SLURM_ARRAY_TASK_ID is not set: this Slurm job is not an array "
          "(submit it with sbatch --array=0-%s)",
          have_n ? "N-1" : "N-1, N the shard count");
    cli_fail(
        "--shard auto: neither SLURM_ARRAY_TASK_ID (a Slurm array job) nor "
        "JOB_COMPLETION_INDEX (a Kubernetes Indexed Job) is set; elsewhere give the "
        "share as --shard I/N");
  }

  if (k8s) {
    /* Kubernetes does not pass .spec.completions to the pod. */
    if (!have_n)
      cli_fail(
          "--shard auto: JOB_COMPLETION_INDEX is %u but the count is not known: give it "
          "as --shard auto/N or BBC_SHARD_COUNT=N (the Job's completions)",
          k8s_id);
    if (k8s_id >= n)
      cli_fail("--shard auto: JOB_COMPLETION_INDEX is %u, not below the shard count %u", k8s_id, n);
    *index = k8s_id;
    *count = n;
    return;
  }

  /* Slurm numbers an array's tasks as sbatch --array says; a shard's index is the task's
   * ID, so the array of N shards is --array=0-(N-1). Without a count given, that array
   * must be whole: a task resubmitted alone (--array=5) sees SLURM_ARRAY_TASK_COUNT=1. */
  if (have_n) {
    if (slurm_id >= n)
      cli_fail(
          "--shard auto: SLURM_ARRAY_TASK_ID is %u, not below the shard count %u (number "
          "the array's tasks from 0: --array=0-%u)",
          slurm_id, n, n - 1);
    *index = slurm_id;
    *count = n;
    return;
  }
  uint32_t task_min = 0, task_max = 0, task_count = 0;
  if (env_u32("SLURM_ARRAY_TASK_COUNT", &task_count) != 0 ||
      env_u32("SLURM_ARRAY_TASK_MIN", &task_min) != 0 ||
      env_u32("SLURM_ARRAY_TASK_MAX", &task_max) != 0)
    cli_fail(
        "--shard auto: SLURM_ARRAY_TASK_ID is %u but SLURM_ARRAY_TASK_COUNT, _MIN or _MAX "
        "is not set; give the count as --shard auto/N or BBC_SHARD_COUNT=N",
        slurm_id);
  if (task_count == 1)
    cli_fail(
        "--shard auto: this array has one task (%u), so it cannot tell the shard count "
        "(a task resubmitted alone sees 1): give the count as --shard auto/N or "
        "BBC_SHARD_COUNT=N",
        slurm_id);
  if (task_min != 0 || task_max != task_count - 1 || slurm_id > task_max)
    cli_fail(
        "--shard auto: the array's tasks are %u..%u, %u of them (SLURM_ARRAY_TASK_MIN, "
        "_MAX, _COUNT), not 0..N-1: submit --array=0-N-1, or give the count as --shard "
        "auto/N or BBC_SHARD_COUNT=N",
        task_min, task_max, task_count);
  *index = slurm_id;
  *count = task_count;
}

void cli_parse_shard(const cli_args *a, const char *text, uint32_t *index, uint32_t *count) {
  if (strncmp(text, "auto", 4) == 0) {
    shard_from_environment(a, text, index, count);
    return;
  }
  char buffer[64];
  const char *slash = strchr(text, '/');
  size_t head = slash ? (size_t)(slash - text) : 0;
  uint32_t i = 0, n = 0;
  if (!slash || head >= sizeof buffer) goto bad;
  memcpy(buffer, text, head);
  buffer[head] = '\0';
  if (parse_u32(buffer, &i) != 0 || parse_u32(slash + 1, &n) != 0) {
    /* Two numbers of digits only, but too large for 32 bits. */
    if (head > 0 && strspn(buffer, "0123456789") == head && slash[1] &&
        strspn(slash + 1, "0123456789") == strlen(slash + 1))
      cli_usage_error(a->usage, "--shard: '%s': numbers too large", text);
    goto bad;
  }
  if (n == 0)
    cli_usage_error(a->usage, "--shard: '%s': the shard count N must be at least 1", text);
  if (i >= n)
    cli_usage_error(a->usage, "--shard: '%s': the shard index I must be below N (0..%u)", text,
                    n - 1);
  *index = i;
  *count = n;
  return;
bad:
  cli_usage_error(a->usage, "--shard: '%s' is not I/N (e.g. 0/4), auto or auto/N", text);
}

/* 1 if name is "<base>.tmp.<digits>" or "<base>.tmp.<digits>.tmp.<digits>": the
 * temporary file of an atomic write of base (libbbc's, or a tool's own whose write went
 * through libbbc's in turn); *pid is the first number. */
static int is_leftover(const char *name, const char *base, long *pid) {
  size_t n = strlen(base);
  if (strncmp(name, base, n) != 0) return 0;
  const char *p = name + n;
  for (int part = 0; part < 2; part++) {
    if (strncmp(p, ".tmp.", 5) != 0 || p[5] < '0' || p[5] > '9') return 0;
    char *end = NULL;
    long v = strtol(p + 5, &end, 10);
    if (part == 0) *pid = v;
    p = end;
    if (*p == '\0') return 1;
  }
  return 0;
}

int cli_remove_leftovers(const char *path) {
  char dir[4096];
  const char *slash = strrchr(path, '/');
  const char *base = slash ? slash + 1 : path;
  if (!slash)
    snprintf(dir, sizeof dir, ".");
  else if (slash == path)
    snprintf(dir, sizeof dir, "/");
  else
    snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);
  if (*base == '\0') return 0;
  DIR *d = opendir(dir);
  if (!d) return 0; /* the write itself will say what is wrong with the folder */
  int removed = 0;
  for (struct dirent *e = readdir(d); e; e = readdir(d)) {
    long pid = 0;
    if (!is_leftover(e->d_name, base, &pid)) continue;
    /* A process of this machine that still runs may be writing it; one of another
     * machine sharing the folder cannot be asked, and is taken for gone. */
    if (pid > 0 && pid != (long)getpid() && (kill((pid_t)pid, 0) == 0 || errno == EPERM)) continue;
    char full[8192];
    snprintf(full, sizeof full, "%s/%s", dir, e->d_name);
    if (unlink(full) == 0) {
      fprintf(stderr, "%s: note: removed %s, left by a run that was stopped while writing\n",
              cli_tool, full);
      removed++;
    }
  }
  closedir(d);
  return removed;
}
