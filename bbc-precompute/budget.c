/* bbc-precompute's memory budget: the default share of the machine, the address space
 * the program maps besides its data, and the RLIMIT_AS that enforces the two. */
#define _GNU_SOURCE /* pthread_getattr_default_np */
#include "budget.h"

#include <ctype.h>
#include <errno.h>
#include <omp.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

#include "cli.h"

#define MB 1048576.0
/* Address space reserved by each bounding thread for its bounder's workspace, mostly
 * never touched (BOUNDER_ARENA_BYTES, libbbc/src/bound/bounder.c). */
#define BOUNDER_WORKSPACE_MB 256.0
/* glibc reserves a heap of 64 MiB for a thread's allocations (HEAP_MAX_SIZE on 64-bit
 * systems), mapping twice that while it aligns it: one such transient, and what else
 * the run maps for a moment, fit in SLACK_MB. */
#define THREAD_HEAP_MB 64.0
#define SLACK_MB 64.0
/* What the main stack may grow to at most, counted when its limit is higher. */
#define MAIN_STACK_MAX_MB 64.0

/* The first number in a file (bytes), or -1 (missing file, "max"). */
static double read_bytes(const char *path) {
  FILE *f = fopen(path, "r");
  double v = -1;
  if (f && fscanf(f, "%lf", &v) != 1) v = -1;
  if (f) fclose(f);
  return v;
}

/* The lowest memory limit of the process's cgroups and their ancestors, bytes, or -1:
 * cgroup v2's memory.max, v1's memory.limit_in_bytes (whose "no limit" is near 2^63). */
static double cgroup_limit(void) {
  FILE *f = fopen("/proc/self/cgroup", "r");
  if (!f) return -1;
  double lowest = -1;
  char line[4096], name[4200];
  while (fgets(line, sizeof line, f)) {
    /* "0::/path" (v2), "4:memory:/path" or "4:cpu,memory:/path" (v1). */
    char *controllers = strchr(line, ':'), *path;
    if (!controllers || !(path = strchr(++controllers, ':'))) continue;
    *path++ = '\0';
    path[strcspn(path, "\n")] = '\0';
    const char *root, *file;
    if (*controllers == '\0')
      root = "/sys/fs/cgroup", file = "memory.max";
    else if (strcmp(controllers, "memory") == 0 || strstr(controllers, ",memory") ||
             strncmp(controllers, "memory,", 7) == 0)
      root = "/sys/fs/cgroup/memory", file = "memory.limit_in_bytes";
    else
      continue;
    /* The cgroup and each ancestor up to the root of the mount. */
    for (char *slash;; *slash = '\0') {
      snprintf(name, sizeof name, "%s%s/%s", root, path, file);
      double v = read_bytes(name);
      if (v > 0 && v < 0x1p60 && (lowest < 0 || v < lowest)) lowest = v;
      if (!(slash = strrchr(path, '/'))) break;
    }
  }
  fclose(f);
  return lowest;
}

/* A line "Name:   123 kB" of a /proc file, bytes, or -1. */
static double proc_field(const char *path, const char *field) {
  FILE *f = fopen(path, "r");
  if (!f) return -1;
  char line[256];
  double v = -1;
  const size_t n = strlen(field);
  while (fgets(line, sizeof line, f))
    if (strncmp(line, field, n) == 0 && line[n] == ':') {
      v = strtod(line + n + 1, NULL) * 1024.0;
      break;
    }
  fclose(f);
  return v;
}

double budget_default_mb(const char **basis) {
  double bytes = proc_field("/proc/meminfo", "MemAvailable");
  *basis = "MemAvailable";
  if (bytes <= 0) {
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    bytes = pages > 0 && page > 0 ? (double)pages * (double)page : -1;
    *basis = "the physical memory";
  }
  const double cgroup = cgroup_limit();
  if (cgroup > 0 && (bytes <= 0 || cgroup < bytes)) {
    bytes = cgroup;
    *basis = "the cgroup's memory limit";
  }
  if (bytes <= 0) {
    bytes = 4096.0 * MB;
    *basis = "4 GiB (the machine's memory is unknown)";
  }
  return 0.75 * bytes / MB;
}

/* The stack of an OpenMP thread, MB: OMP_STACKSIZE (or GOMP_STACKSIZE) as libgomp reads
 * it (a size in KiB, or with a suffix B, K, M or G), else the threads' default. */
static double thread_stack_mb(void) {
  const char *text = getenv("OMP_STACKSIZE");
  if (!text) text = getenv("GOMP_STACKSIZE");
  if (text) {
    char *end = NULL;
    const double v = strtod(text, &end);
    while (isspace((unsigned char)*end)) end++;
    const int unit = toupper((unsigned char)*end);
    const double scale = unit == 'B' ? 1 : unit == 'M' ? MB : unit == 'G' ? 1024 * MB : 1024;
    if (end != text && v > 0) return v * scale / MB;
  }
  pthread_attr_t attr;
  size_t size = 0;
  if (pthread_getattr_default_np(&attr) == 0) {
    pthread_attr_getstacksize(&attr, &size);
    pthread_attr_destroy(&attr);
  }
  return size ? (double)size / MB : 8.0;
}

void budget_allowances(budget *b, int bounders) {
  /* Mapped now: the program, its libraries and what a sanitizer reserves. */
  const double mapped = proc_field("/proc/self/status", "VmSize");
  double fixed = (mapped > 0 ? mapped / MB : 256.0) + SLACK_MB;
  struct rlimit stack;
  double main_stack = MAIN_STACK_MAX_MB;
  if (getrlimit(RLIMIT_STACK, &stack) == 0 && stack.rlim_cur != RLIM_INFINITY &&
      (double)stack.rlim_cur / MB < main_stack)
    main_stack = (double)stack.rlim_cur / MB;
  fixed += main_stack;
  /* The bounding runs `bounders` threads, each with a workspace; the loading, the grids
   * and the writer run one per core (omp_get_max_threads). OpenMP keeps its threads,
   * each but the main one with its own stack and heap. */
  const int threads = omp_get_max_threads() > bounders ? omp_get_max_threads() : bounders;
  fixed += (threads - 1) * (thread_stack_mb() + THREAD_HEAP_MB);
  b->allowance_mb = fixed + bounders * BOUNDER_WORKSPACE_MB;
  b->writing_mb = fixed;
}

int budget_enforce(budget *b) {
  const double want = (b->mb + b->allowance_mb) * MB;
  struct rlimit now;
  if (getrlimit(RLIMIT_AS, &now) != 0) return 0;
  if (now.rlim_cur != RLIM_INFINITY && (double)now.rlim_cur <= want) {
    /* The user's limit is lower: it stays, and the budget is what it leaves. */
    b->limit_mb = (double)now.rlim_cur / MB;
    b->mb = b->limit_mb - b->allowance_mb;
    b->source = "ulimit -v";
    b->kept = 1;
    if (b->mb < 1) {
      fprintf(stderr,
              "%s: the address-space limit of %.0f MB (ulimit -v) leaves no room for the "
              "precompute: the program maps %.0f MB itself; raise the limit or use fewer "
              "--threads\n",
              cli_tool, b->limit_mb, b->allowance_mb);
      return -1;
    }
    return 0;
  }
  struct rlimit next = {(rlim_t)want, now.rlim_max};
  if (setrlimit(RLIMIT_AS, &next) != 0) {
    fprintf(stderr,
            "%s: warning: cannot limit the address space (%s): the memory budget is "
            "not enforced\n",
            cli_tool, strerror(errno));
    return 0;
  }
  b->limit_mb = want / MB;
  return 0;
}

void budget_enter_writing(const budget *b) {
  struct rlimit now;
  const double want = (b->mb + b->writing_mb) * MB;
  if (b->limit_mb <= 0 || getrlimit(RLIMIT_AS, &now) != 0) return;
  if (now.rlim_cur != RLIM_INFINITY && (double)now.rlim_cur <= want) return;
  struct rlimit next = {(rlim_t)want, now.rlim_max};
  setrlimit(RLIMIT_AS, &next); /* lowering a soft limit does not fail */
}
