/* The memory budget of bbc-precompute (--memory): its default share of the machine and
 * its enforcement through RLIMIT_AS, so that running out of memory is an allocation that
 * fails inside the process (one line, exit 1) rather than the kernel's OOM killer. */
#ifndef BBC_PRECOMPUTE_BUDGET_H
#define BBC_PRECOMPUTE_BUDGET_H

/* The largest --memory accepted, MB (1 PiB: beyond the memory of any machine). */
#define BUDGET_MAX_MB 1073741824.0

typedef struct budget {
  double requested_mb; /* what --memory or the default asked for (MB = MiB) */
  double mb;           /* the precompute's data may use this much */
  double allowance_mb; /* what the program maps besides its data while bounding */
  double writing_mb;   /* and while writing the cache (budget_allowances) */
  double limit_mb;     /* the RLIMIT_AS while bounding, MB; 0 when none could be set */
  const char *source;  /* "--memory", "default" or "ulimit -v" (a lower limit was kept) */
  int kept;            /* the user's lower limit was kept (source "ulimit -v") */
  const char *basis;   /* for the default: what it is 3/4 of */
} budget;

/* The default budget, MB: 3/4 of the memory the machine can give the run when it starts,
 * the smaller of MemAvailable (/proc/meminfo; the physical memory from sysconf where that
 * is unknown) and the memory limit of the process's cgroup and its ancestors (containers,
 * batch schedulers). *basis names the one used. */
double budget_default_mb(const char **basis);

/* Sets b->allowance_mb and b->writing_mb: the address space bbc-precompute maps besides
 * its data while bounding with `bounders` threads and while writing the cache. That is
 * what is mapped when this is called (the program, its libraries, a sanitizer's
 * reservations), the main stack's limit, per OpenMP thread its stack and malloc heap,
 * and per bounding thread the bounder's workspace, freed before the writing. */
void budget_allowances(budget *b, int bounders);

/* Sets RLIMIT_AS to b->mb + b->allowance_mb. A lower soft limit already in place (the
 * user's ulimit -v) is kept, and b->mb becomes what it leaves beside the allowance, with
 * b->kept set and b->source "ulimit -v". Fills b->limit_mb. Returns 0, or -1 after a one-line
 * message when the kept limit leaves no room at all for the data. */
int budget_enforce(budget *b);

/* Once the bounding is over: lowers the limit to b->mb + b->writing_mb, so that the
 * bounders' freed workspaces do not become room for the data beyond the budget. */
void budget_enter_writing(const budget *b);

#endif
