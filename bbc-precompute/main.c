/* bbc-precompute: bounds the caustics of a glTF scene into a .bbc cache. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <omp.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include "bbc/bbc.h"
#include "bbc/precompute.h"
#include "budget.h"
#include "cli.h"

static const char usage[] =
    "usage: bbc-precompute SCENE.gltf -o OUT.bbc [options]   (bbc-precompute --help for all)\n";

static const char help[] =
    "bbc-precompute: bound the caustics of a glTF scene into a .bbc cache.\n"
    "\n"
    "usage: bbc-precompute SCENE.gltf -o OUT.bbc [options]\n"
    "\n"
    "For every point light, specular triangle and receiver triangle its beam can reach\n"
    "(a tuple), the domain of the specular triangle is subdivided and conservative\n"
    "bounds of where the caustic lands and how bright it is are recorded per cell of\n"
    "each receiver's grid (Fan et al. 2025, Sec. 4-6).\n"
    "\n"
    "Output:\n"
    "  -o, --output FILE     the cache to write (required); written to a temporary file\n"
    "                        and renamed, so no partial file is ever left at FILE\n"
    "  --stats               print the precompute statistics (the paper's Table 2\n"
    "                        columns) to stderr\n"
    "  --json FILE           write the statistics as JSON to FILE\n"
    "  --no-geometry         do not store the scene's geometry in the cache (smaller\n"
    "                        file; a re-export whose floats moved in their last bits,\n"
    "                        as Blender's do, is then refused as another scene instead\n"
    "                        of matched within the quanta, format-spec Sec. 8.1)\n"
    "  --allow-empty         write the cache even when it holds no tuple although the\n"
    "                        scene has casters (otherwise that is an error, exit 1, with\n"
    "                        the reason: no point light, --chains, no reach, culled)\n"
    "\n"
    "Bounds:\n"
    "  --chains LIST         chain types, comma-separated: R, T, RR, RT, TR, TT (R\n"
    "                        reflects on a mirror, T refracts through a dielectric, in\n"
    "                        the light's order); default: every type the materials\n"
    "                        can form, less the two-bounce types over --double-budget\n"
    "  --double-budget MIN   without --chains: leave to bbc-render's light tracing the\n"
    "                        costliest two-bounce chain types (RR, RT, TR, TT) until\n"
    "                        bounding the rest would take about MIN minutes of CPU or\n"
    "                        less (default 10; 0 leaves them all out). The cost is\n"
    "                        estimated from 16 candidates of each type bounded first\n"
    "                        and counted in pieces, 240,000 to the minute, not clocked,\n"
    "                        so the cache is the same on any machine. With beam\n"
    "                        receivers (--receivers) all of them are left out. A type\n"
    "                        left out is light-traced where the camera sees its\n"
    "                        caustic directly, and missing in mirrors and through glass\n"
    "  --max-level N         deepest subdivision level of a tuple's domain (default 10,\n"
    "                        and 3 for two-bounce tuples unless N is given: deeper\n"
    "                        ones cost far more and render no better); a two-bounce\n"
    "                        piece whose irradiance bound is unbounded\n"
    "                        may be split once more, and one whose position bound is\n"
    "                        still 4 --sigma or more in area down to four levels more\n"
    "                        for its position alone (point lights, spots and suns)\n"
    "  --max-level2 N        the same for the two-bounce tuples of point lights, spots\n"
    "                        and suns alone (1-30; default 3, or --max-level N)\n"
    "  --sigma S             stop subdividing when the position bound's area (receiver\n"
    "                        barycentric units) is below S (default 1e-4); not used\n"
    "                        for area lights\n"
    "  --alpha A             stop when the irradiance bound's upper/lower ratio is\n"
    "                        below A (default 2), one specular vertex\n"
    "  --alpha2 A            the same for two specular vertices (default 10)\n"
    "  --alpha-area A        the same for every tuple of an area light (default 100:\n"
    "                        the emitter point drawn at render time, not the choice\n"
    "                        of tuples, sets their error; docs/lights.md)\n"
    "  --m M                 solutions assumed per tuple, Eq. 21 (default 1)\n"
    "  --resolution N        cells along the longer side of each receiver grid\n"
    "                        (default 512)\n"
    "  --area-lights         cache the single-scattering caustics (R, T of --chains) of\n"
    "                        emissive triangles too; the renderer then leaves them to\n"
    "                        the cache instead of path tracing (docs/lights.md)\n"
    "  --area-double         with --area-lights, their double-scattering chain types of\n"
    "                        --chains (RR, RT, TR, TT) too: far costlier to bound\n"
    "  --receivers MODE      auto (default), per-triangle or beam: whether receiver\n"
    "                        triangles not on a plane end one tuple each, or one beam\n"
    "                        tuple per specular prefix stands for all of them\n"
    "                        (docs/receivers.md): beam costs the same on a finely cut\n"
    "                        curved receiver as on a coarse one; auto takes beam when\n"
    "                        such receivers hold 1000 triangles or more\n"
    "  --no-remainder        drop the remainder variables of refraction: faster, but the\n"
    "                        bounds are no longer conservative (the paper's Fig. 18)\n"
    "  --jacobian FORM       determinant (default) or quotient: the form of the\n"
    "                        irradiance Jacobian\n"
    "\n"
    "Scene:\n"
    "  --light-units U       photometric or radiometric: how light intensities are read\n"
    "                        (default: the file's asset.extras.bbc.light_units, else\n"
    "                        photometric, as glTF says: candela and lux, / 683 lm/W)\n"
    "\n"
    "Execution:\n"
    "  --threads N           worker threads (default: every core); the cache is\n"
    "                        byte-identical for any thread count\n"
    "  --memory MB           the memory budget (default: 3/4 of the memory available when\n"
    "                        the run starts: MemAvailable, or the cgroup's memory limit\n"
    "                        if lower). The address space is limited to it plus what\n"
    "                        the program maps itself (libraries; per thread a stack, a\n"
    "                        malloc heap and the bounder's 256 MB workspace; see\n"
    "                        --stats), so that going beyond it fails with one line\n"
    "                        (exit 1, no output) instead of the kernel killing the run.\n"
    "                        A grid whose least memory exceeds it is refused before any\n"
    "                        work; a lower ulimit -v is kept. The candidate tuples are\n"
    "                        counted first (a progress bar 'finding tuples'), a sample\n"
    "                        of them bounded, and the estimate (candidates per chain\n"
    "                        type, time, memory, file size) printed with the bar, --stats\n"
    "                        or --dry-run; a precompute whose estimated memory exceeds\n"
    "                        the budget is refused then, in one line with the estimate,\n"
    "                        before any bounding. A candidate list over 1/16 of the\n"
    "                        budget is never held: it is searched again, a block at a\n"
    "                        time, while it is bounded\n"
    "  --entry-memory MB     memory for grid entries (default 8); beyond it they are\n"
    "                        spilled to a temporary file in $TMPDIR (or /tmp), deleted\n"
    "                        on any exit; the cache does not depend on it\n"
    "  --dry-run             count the candidate tuples, bound a sample of them and print\n"
    "                        the estimate (tuples, time, memory, file size), then stop;\n"
    "                        -o is not needed and nothing is written\n"
    "  --ignore-estimate     bound even when the estimate says the budget will not do\n"
    "                        (the budget still holds: past it the run fails in one line)\n"
    "  --shard I/N           bound only the candidate tuples k with k % N == I\n"
    "                        (0 <= I < N) and write a shard cache; the N shards, run\n"
    "                        anywhere, merge with 'bbc-inspect merge OUT.bbc SHARD...'\n"
    "                        into the cache this command writes without --shard, byte\n"
    "                        for byte. bbc-render refuses a shard alone\n"
    "  --shard auto          I/N from the job scheduler: I is SLURM_ARRAY_TASK_ID (a\n"
    "                        Slurm array, sbatch --array=0-(N-1)) or JOB_COMPLETION_INDEX\n"
    "                        (a Kubernetes Indexed Job); N is BBC_SHARD_COUNT if set,\n"
    "                        else the Slurm array's task count (the array must be all of\n"
    "                        0..N-1: a task resubmitted alone sees a count of 1)\n"
    "  --shard auto/N        the same with the count N; a missing or inconsistent\n"
    "                        variable is an error (exit 1). A temporary file that a\n"
    "                        killed run left beside OUT is removed (docs/cluster.md)\n"
    "  --progress            show a progress bar (default: when stderr is a terminal)\n"
    "  --no-progress         never show one\n"
    "  --version             print versions and exit\n"
    "  -h, --help            print this help and exit\n"
    "\n"
    "Exit status: 0 on success, 1 on a runtime failure (bad scene, I/O, out of memory\n"
    "within the budget), 2 on bad usage, 130 when interrupted (no output is left behind).\n";

/* "; OUT was not written" after a failure, or nothing for --dry-run (no output). */
static const char *not_written(const char *output) {
  static char text[4200];
  if (!output) return "";
  snprintf(text, sizeof text, "; %s was not written", output);
  return text;
}

static int on_progress(void *user, uint64_t done, uint64_t total) {
  char detail[64];
  snprintf(detail, sizeof detail, "%llu/%llu tuples", (unsigned long long)done,
           (unsigned long long)total);
  cli_progress_update(user, total ? (double)done / (double)total : 1.0, detail);
  return cli_interrupted;
}

/* The search for the candidates: (light, first triangle) prefixes searched of all. */
static int on_search_progress(void *user, uint64_t done, uint64_t total) {
  char detail[64];
  snprintf(detail, sizeof detail, "%llu/%llu light-triangle prefixes", (unsigned long long)done,
           (unsigned long long)total);
  cli_progress_update(user, total ? (double)done / (double)total : 1.0, detail);
  return cli_interrupted;
}

/* --memory MB: a number from 1 to BUDGET_MAX_MB; anything else is a usage error. */
static double parse_memory(const cli_args *a, const char *text) {
  const double mb = cli_parse_double(a, "--memory", text, -HUGE_VAL, HUGE_VAL);
  if (mb < 1) cli_usage_error(usage, "--memory: %s MB is too small a budget (at least 1)", text);
  if (mb > BUDGET_MAX_MB)
    cli_usage_error(usage, "--memory: %s MB is beyond any machine's memory (at most %.0f, 1 PiB)",
                    text, BUDGET_MAX_MB);
  return mb;
}

/* What the line of a failure needs to know about the run. */
typedef struct run_context {
  const budget *memory;
  const char *scene, *output;
  const char *phase; /* "while bounding the candidate tuples" etc.; NULL for the up-front
                        check */
  cli_progress *bar;
  int show_estimate; /* print the estimate (the bar is on, or --stats or --dry-run) */
  int dry_run;       /* stop after the estimate */
  int ignore_estimate; /* bound even when the estimate is over the budget */
  double start_bytes;  /* resident_bytes when the run started */
  int refused;       /* the estimate did not fit the budget */
  uint32_t shard_count;
} run_context;

/* libbbc's messages, one line each. Running out of memory is the budget's doing (the
 * address-space limit makes the allocation past it fail), so that line says the budget
 * was exceeded and how to change it, once, whichever thread met it first. */
static void on_error(void *user, bbc_result code, const char *message) {
  static atomic_flag said = ATOMIC_FLAG_INIT;
  const run_context *run = user;
  if (code != BBC_ERR_OUT_OF_MEMORY) {
    cli_print_message(NULL, code, message);
    return;
  }
  if (atomic_flag_test_and_set(&said)) return;
  const char *option = run->memory->kept ? "ulimit -v" : "--memory";
  if (!run->phase)
    fprintf(stderr, "%s: %s (%s)\n", cli_tool, message, option);
  else
    fprintf(stderr,
            "%s: %s: out of memory within the budget of %.0f MB (%s) %s%s\n", cli_tool,
            run->scene, run->memory->mb, option, run->phase, not_written(run->output));
}

/* "1.2e8" for large counts, the number itself below a million. */
static const char *count_text(uint64_t n, char out[32]) {
  if (n < 1000000) {
    snprintf(out, 32, "%llu", (unsigned long long)n);
    return out;
  }
  int e = (int)floor(log10((double)n));
  double m = (double)n / pow(10, e);
  if (m >= 9.95) m /= 10, e++;
  snprintf(out, 32, "%.1fe%d", m, e);
  return out;
}

/* "2.4 GB", "16 MB" or "12 kB" (powers of 1024, as --memory's MB). */
static const char *bytes_text(double bytes, char out[32]) {
  if (bytes >= 1024.0 * 1048576.0)
    snprintf(out, 32, "%.1f GB", bytes / (1024.0 * 1048576.0));
  else if (bytes >= 1048576.0)
    snprintf(out, 32, "%.0f MB", bytes / 1048576.0);
  else
    snprintf(out, 32, "%.0f kB", bytes / 1024.0);
  return out;
}

/* "45 s", "12 min", "3.1 h", "2.0 days". */
static const char *seconds_text(double s, char out[32]) {
  if (s < 90)
    snprintf(out, 32, "%.0f s", s);
  else if (s < 5400)
    snprintf(out, 32, "%.0f min", s / 60);
  else if (s < 172800)
    snprintf(out, 32, "%.1f h", s / 3600);
  else
    snprintf(out, 32, "%.1f days", s / 86400);
  return out;
}

/* The memory the process holds (VmRSS), bytes; 0 if unknown. */
static double resident_bytes(void) {
  FILE *f = fopen("/proc/self/status", "r");
  if (!f) return 0;
  char line[256];
  double kb = 0;
  while (fgets(line, sizeof line, f))
    if (strncmp(line, "VmRSS:", 6) == 0) kb = strtod(line + 6, NULL);
  fclose(f);
  return kb * 1024.0;
}

/* "TT 1.1e8, T 5.3e6": the candidates per chain type, most first. */
static void chains_text(const bbc_precompute_estimate *e, char *out, size_t size) {
  int done[BBC_CHAIN_COUNT] = {0};
  out[0] = '\0';
  for (;;) {
    int best = -1;
    for (int c = 0; c < BBC_CHAIN_COUNT; c++)
      if (!done[c] && e->candidates_per_chain[c] &&
          (best < 0 || e->candidates_per_chain[c] > e->candidates_per_chain[best]))
        best = c;
    if (best < 0) break;
    done[best] = 1;
    char n[32];
    size_t used = strlen(out);
    snprintf(out + used, size - used, "%s%s %s", used ? ", " : "",
             bbc_chain_name((bbc_chain)best), count_text(e->candidates_per_chain[best], n));
  }
}

/* libbbc's estimate, before the bounding: printed when asked, and checked against the
 * budget: a precompute whose memory would not fit is refused here, in one line, before
 * anything is bounded. */
static int on_estimate(void *user, const bbc_precompute_estimate *e) {
  run_context *run = user;
  cli_progress_end(run->bar);
  char chains[160];
  chains_text(e, chains, sizeof chains);
  /* What the run holds now beyond what the program held when it started (its code and
   * libraries, which the budget's allowance holds). */
  const double held = fmax(0, resident_bytes() - run->start_bytes);
  const double need = held + (double)e->memory_bytes;
  const double budget_bytes = run->memory->mb * 1048576.0;
  const char *option = run->memory->kept ? "ulimit -v" : "--memory";
  if (need > budget_bytes && !run->ignore_estimate) {
    /* Sharding divides the stored tuples, the part that grows with the candidates. */
    const double fixed = held + (double)e->memory_bytes -
                         (double)e->stored_tuples * (run->shard_count ? 56.0 : 40.0);
    char shard[96] = "";
    const double per = (double)e->stored_tuples * 56.0;
    if (!run->shard_count && budget_bytes > fixed && per > 0) {
      const double n = ceil(per / (budget_bytes - fixed));
      if (n >= 2 && n < 1e6)
        snprintf(shard, sizeof shard, "--shard I/%.0f (each of I = 0..%.0f, then merged), ", n,
                 n - 1);
    }
    char n1[32], n2[32], l1[32], m1[32], m2[32], m3[32], m4[32];
    fprintf(stderr,
            "%s: %s: %s candidate tuples (%s; %s as a list), up to %s of them stored: the "
            "precompute needs about %s (%s held now, %s more), over the budget of %s (%s); "
            "try %sfewer --chains or a larger %s%s\n",
            cli_tool, run->scene, count_text(e->candidate_tuples, n1), chains,
            bytes_text((double)e->list_bytes, l1), count_text(e->stored_tuples, n2),
            bytes_text(need, m1), bytes_text(held, m2), bytes_text((double)e->memory_bytes, m3),
            bytes_text(budget_bytes, m4), option, shard, option, not_written(run->output));
    run->refused = 1;
    return 1;
  }
  if (run->show_estimate) {
    char sample[160] = "", t1[32], t2[32], n1[32], s1[32], m1[32], m2[32], l1[32], f1[32];
    if (e->sample_tuples)
      snprintf(sample, sizeof sample,
               "from %u sampled: bounding about %s CPU (%s wall), %.0f%% stored, ",
               e->sample_tuples, seconds_text(e->bounding_cpu_seconds, t1),
               seconds_text(e->seconds, t2), 100 * e->stored_fraction);
    fprintf(stderr,
            "%s: estimate: %s candidate tuples (%s), found in %s; %s as a list, %s; %smemory "
            "up to %s of the budget of %s (%s), cache %s %s\n",
            cli_tool, count_text(e->candidate_tuples, n1), chains[0] ? chains : "none",
            seconds_text(e->search_seconds, s1), bytes_text((double)e->list_bytes, l1),
            e->list_held ? "held" : "searched again in blocks while bounding", sample,
            bytes_text(need, m1), bytes_text(budget_bytes, m2), run->memory->source,
            e->sample_tuples ? "about" : "at least", bytes_text((double)e->file_bytes, f1));
  }
  if (run->dry_run) return 1;
  cli_progress_begin(run->bar, "bounding", run->bar->enabled);
  run->phase = "while bounding the candidate tuples";
  return 0;
}

/* The line that says which two-bounce chain types the default leaves out, and why. */
static void say_left_out(const bbc_chain_choice *c, double budget_minutes, int beams) {
  char list[320] = "", all[64] = "", n[32], t[32];
  double kept = 0;
  for (int k = 0; k < BBC_CHAIN_COUNT; k++) {
    if (!(c->left_out & BBC_CHAIN_BIT(k))) {
      kept += c->pieces[k];
      continue;
    }
    size_t used = strlen(list);
    if (c->candidates[k])
      snprintf(list + used, sizeof list - used, "%s%s (%s candidates, about %s CPU)",
               used ? ", " : "", bbc_chain_name((bbc_chain)k), count_text(c->candidates[k], n),
               seconds_text(c->pieces[k] / BBC_DOUBLE_PIECES_PER_SECOND, t));
    else
      snprintf(list + used, sizeof list - used, "%s%s", used ? ", " : "",
               bbc_chain_name((bbc_chain)k));
  }
  for (int k = 0; k < BBC_CHAIN_COUNT; k++) {
    if (!(c->chains & BBC_CHAIN_BIT(k)) && !(c->left_out & BBC_CHAIN_BIT(k))) continue;
    size_t used = strlen(all);
    snprintf(all + used, sizeof all - used, "%s%s", used ? "," : "", bbc_chain_name((bbc_chain)k));
  }
  char b[32], r[32] = "";
  if (budget_minutes > 0) snprintf(r, sizeof r, " of %s CPU", seconds_text(budget_minutes * 60, b));
  char rest[96] = "";
  if (kept > 0)
    snprintf(rest, sizeof rest, "; the two-bounce types kept take about %s",
             seconds_text(kept / BBC_DOUBLE_PIECES_PER_SECOND, b));
  char why[160];
  if (beams)
    snprintf(why, sizeof why,
             "with beam receivers (two-bounce beam tuples cost the render "
             "more than light tracing)");
  else
    snprintf(why, sizeof why, "over --double-budget%s%s", budget_minutes > 0 ? r : " 0", rest);
  fprintf(stderr,
          "bbc-precompute: chains: %s left to bbc-render's light tracing, %s: light-traced "
          "where the camera sees their caustic directly, missing in mirrors and through "
          "glass (--chains %s bounds them)\n",
          list, why, all);
}

static int has_caster(const bbc_scene *scene) {
  for (uint32_t i = 0; i < scene->mesh_count; i++)
    if (scene->meshes[i].role == BBC_ROLE_CASTER) return 1;
  return 0;
}

/* Why a precompute stored no tuple (NULL when it stored some), in the order a user
 * would check: casters, point lights, chain types, reach, culling. */
static const char *why_empty(const bbc_scene *scene, uint32_t chains,
                             const bbc_precompute_stats *st) {
  if (st->tuples > 0) return NULL;
  int mirror = 0, dielectric = 0;
  for (uint32_t i = 0; i < scene->mesh_count; i++) {
    const bbc_mesh *m = &scene->meshes[i];
    if (m->role != BBC_ROLE_CASTER) continue;
    mirror |= scene->materials[m->material].type == BBC_MATERIAL_MIRROR;
    dielectric |= scene->materials[m->material].type == BBC_MATERIAL_DIELECTRIC;
  }
  if (!mirror && !dielectric)
    return "no mesh is a caster (no mirror or smooth dielectric, or none with role caster)";
  if (scene->point_light_count == 0)
    return "the scene has no point light (caustics of area lights are path traced, not cached)";
  int possible = 0;
  for (int c = 0; c < BBC_CHAIN_COUNT; c++) {
    if (!(chains & BBC_CHAIN_BIT(c))) continue;
    int ok = 1;
    for (int v = 0; v < bbc_chain_length((bbc_chain)c); v++)
      ok &= bbc_chain_refracts((bbc_chain)c, v) ? dielectric : mirror;
    possible |= ok;
  }
  if (!possible)
    return mirror && dielectric ? "no chain type asked for (--chains) can be formed"
           : mirror             ? "the casters are all mirrors, but --chains asks for no R-only chain"
                                : "the casters are all dielectrics, but --chains asks for no T-only chain";
  if (st->candidate_tuples == 0)
    return "no light path reaches a receiver through one or two casters (no candidate tuple: "
           "check the roles, the light's position and the casters' normals; light through "
           "more surfaces, as in a hollow glass, is light-traced by bbc-render --light-trace "
           "on without a cache)";
  return "every candidate tuple was culled: none carries light to a receiver";
}

/* Writes s as a JSON string literal. */
static void json_string(FILE *f, const char *s) {
  fputc('"', f);
  for (; *s; s++) {
    unsigned char c = (unsigned char)*s;
    if (c == '"' || c == '\\')
      fprintf(f, "\\%c", c);
    else if (c < 0x20)
      fprintf(f, "\\u%04x", c);
    else
      fputc(c, f);
  }
  fputc('"', f);
}

/* OpenMP's threads spin while they wait at the end of a batch by default, and the
 * spinning is CPU time that does no work: a quarter of the CPU time of ball5120 TT at
 * level 1 on two busy cores. The wait policy is read when the OpenMP runtime is loaded,
 * before main, so when the environment does not choose one the tool sets PASSIVE and
 * executes itself once more (if that fails it goes on as it is). */
static void passive_openmp(char **argv) {
  if (getenv("OMP_WAIT_POLICY")) return;
  if (setenv("OMP_WAIT_POLICY", "PASSIVE", 1) != 0) return;
  execv("/proc/self/exe", argv);
}

int main(int argc, char **argv) {
  passive_openmp(argv);
  cli_tool = "bbc-precompute";
  cli_args a = {argc, argv, 1, usage};
  const char *scene_path = NULL, *output = NULL, *json = NULL, *value = NULL;
  bbc_precompute_options options;
  memset(&options, 0, sizeof options);
  bbc_precompute_params_default(&options.params);
  int progress = -1, stats = 0, allow_empty = 0, no_geometry = 0, alpha_area_given = 0;
  int dry_run = 0, ignore_estimate = 0, receivers_auto = 1;
  double memory_mb = 0; /* --memory; 0: the default */
  int chains_given = 0, max_level_given = 0;
  uint32_t level2 = 0;       /* --max-level2; 0: not given */
  double double_budget = 10; /* --double-budget, minutes of CPU */
  bbc_light_units light_units = BBC_LIGHT_UNITS_FILE;

  while (a.i < argc) {
    const char *arg = argv[a.i];
    if (cli_flag(&a, "-h") || cli_flag(&a, "--help")) {
      fputs(help, stdout);
      return 0;
    } else if (cli_flag(&a, "--version")) {
      /* Without GEOM the minor version is the smallest the file needs (R-HDR-3). */
      printf("bbc-precompute %s (libbbc %s, writes .bbc format %d.3, %d.%d with --area-lights; "
             "with --no-geometry %d.0, %d.1 with --shard)\n",
             bbc_version_string(), bbc_version_string(), BBC_FORMAT_VERSION_MAJOR,
             BBC_FORMAT_VERSION_MAJOR, BBC_FORMAT_VERSION_MINOR, BBC_FORMAT_VERSION_MAJOR,
             BBC_FORMAT_VERSION_MAJOR);
      return 0;
    } else if (cli_option(&a, "-o", &value) || cli_option(&a, "--output", &value)) {
      output = value;
    } else if (cli_option(&a, "--json", &value)) {
      json = value;
    } else if (cli_flag(&a, "--no-geometry")) {
      no_geometry = 1;
    } else if (cli_flag(&a, "--stats")) {
      stats = 1;
    } else if (cli_option(&a, "--chains", &value)) {
      options.params.chains = cli_parse_chains(&a, "--chains", value);
      chains_given = 1;
    } else if (cli_option(&a, "--double-budget", &value)) {
      double_budget = cli_parse_double(&a, "--double-budget", value, 0, 1e9);
    } else if (cli_option(&a, "--max-level", &value)) {
      options.params.max_level = (uint32_t)cli_parse_int(&a, "--max-level", value, 0, 30);
      max_level_given = 1;
    } else if (cli_option(&a, "--max-level2", &value)) {
      level2 = (uint32_t)cli_parse_int(&a, "--max-level2", value, 1, 30);
    } else if (cli_option(&a, "--sigma", &value)) {
      options.params.sigma = cli_parse_double(&a, "--sigma", value, 0, 1);
    } else if (cli_option(&a, "--alpha", &value)) {
      options.params.alpha_single = cli_parse_double(&a, "--alpha", value, 1, 1e30);
    } else if (cli_option(&a, "--alpha2", &value)) {
      options.params.alpha_double = cli_parse_double(&a, "--alpha2", value, 1, 1e30);
    } else if (cli_option(&a, "--alpha-area", &value)) {
      options.params.alpha_area = cli_parse_double(&a, "--alpha-area", value, 1, 1e30);
      alpha_area_given = 1;
    } else if (cli_option(&a, "--m", &value)) {
      options.params.m = cli_parse_double(&a, "--m", value, 1e-6, 1e6);
    } else if (cli_option(&a, "--resolution", &value)) {
      options.params.grid_resolution = (uint32_t)cli_parse_int(&a, "--resolution", value, 1, 65536);
    } else if (cli_flag(&a, "--no-remainder")) {
      options.params.remainder = 0;
    } else if (cli_flag(&a, "--area-lights")) {
      options.params.area_lights = 1;
    } else if (cli_flag(&a, "--area-double")) {
      options.params.area_double = 1;
    } else if (cli_option(&a, "--receivers", &value)) {
      receivers_auto = strcmp(value, "auto") == 0;
      if (strcmp(value, "per-triangle") == 0)
        options.params.beam_receivers = 0;
      else if (strcmp(value, "beam") == 0)
        options.params.beam_receivers = 1;
      else if (!receivers_auto)
        cli_usage_error(usage, "--receivers: '%s' is not auto, per-triangle or beam", value);
    } else if (cli_option(&a, "--jacobian", &value)) {
      if (strcmp(value, "determinant") == 0)
        options.jacobian = BBC_JACOBIAN_DETERMINANT;
      else if (strcmp(value, "quotient") == 0)
        options.jacobian = BBC_JACOBIAN_QUOTIENT;
      else
        cli_usage_error(usage, "--jacobian: '%s' is neither determinant nor quotient", value);
    } else if (cli_flag(&a, "--allow-empty")) {
      allow_empty = 1;
    } else if (cli_option(&a, "--light-units", &value)) {
      light_units = cli_parse_light_units(&a, "--light-units", value);
    } else if (cli_option(&a, "--threads", &value)) {
      options.threads = (int)cli_parse_int(&a, "--threads", value, 1, 1024);
    } else if (cli_option(&a, "--memory", &value)) {
      memory_mb = parse_memory(&a, value);
    } else if (cli_option(&a, "--entry-memory", &value)) {
      double mb = cli_parse_double(&a, "--entry-memory", value, 1e-6, 1e6);
      options.entry_memory = (size_t)(mb * 1048576.0);
    } else if (cli_option(&a, "--shard", &value)) {
      cli_parse_shard(&a, value, &options.shard_index, &options.shard_count);
    } else if (cli_flag(&a, "--dry-run")) {
      dry_run = 1;
    } else if (cli_flag(&a, "--ignore-estimate")) {
      ignore_estimate = 1;
    } else if (cli_flag(&a, "--progress")) {
      progress = 1;
    } else if (cli_flag(&a, "--no-progress")) {
      progress = 0;
    } else if (arg[0] == '-' && arg[1] != '\0') {
      cli_usage_error(usage, "unknown option '%s'", arg);
    } else if (!scene_path) {
      scene_path = arg;
      a.i++;
    } else {
      cli_usage_error(usage, "unexpected argument '%s'", arg);
    }
  }
  if (!scene_path) cli_usage_error(usage, "no scene given");
  /* --max-level N alone sets every tuple's level (0: the same as max_level). */
  if (level2 || max_level_given) options.params.max_level_double = level2;
  if (!output && !dry_run) cli_usage_error(usage, "no output given (-o OUT.bbc)");
  if (options.params.area_double && !options.params.area_lights)
    cli_usage_error(usage, "--area-double needs --area-lights");
  if (alpha_area_given && !options.params.area_lights)
    cli_usage_error(usage, "--alpha-area needs --area-lights");
  if (options.params.area_double && !(options.params.chains & BBC_CHAIN_MASK_DOUBLE))
    cli_usage_error(usage, "--area-double needs a double-scattering chain type in --chains");

  /* The budget holds from here on, the scene's loading included. */
  budget memory = {0};
  memory.source = memory_mb > 0 ? "--memory" : "default";
  memory.requested_mb = memory.mb = memory_mb > 0 ? memory_mb : budget_default_mb(&memory.basis);
  budget_allowances(&memory, options.threads > 0 ? options.threads : omp_get_max_threads());
  if (budget_enforce(&memory) != 0) return 1;
  run_context run = {&memory, scene_path, output, "while loading the scene", NULL, 0, 0, 0, 0, 0,
                     resident_bytes()};

  cli_catch_interrupts();
  /* A rerun of a task that was killed while writing (so that libbbc could not remove
   * its temporary file) leaves nothing of that run behind. */
  if (output) cli_remove_leftovers(output);

  double start = cli_now();
  bbc_scene_options scene_options = {on_error, cli_print_warning, &run, light_units};
  bbc_scene *scene = NULL;
  if (bbc_scene_load(&scene, scene_path, &scene_options) != BBC_OK) return 1;
  run.phase = NULL;
  if (receivers_auto) {
    uint64_t curved = 0;
    options.params.beam_receivers = bbc_beam_receivers_auto(scene, &curved);
    if (options.params.beam_receivers)
      fprintf(stderr,
              "bbc-precompute: receivers: beam (%llu receiver triangles not on a plane; "
              "--receivers per-triangle gives each its own tuples)\n",
              (unsigned long long)curved);
  }
  if (bbc_cache_check_resources(scene, &options.params, dry_run ? NULL : output,
                                (uint64_t)(memory.mb * 1048576.0), on_error, &run) != BBC_OK) {
    bbc_scene_free(scene);
    return 1;
  }

  cli_progress bar;
  options.cancel_fn = cli_interrupt_requested; /* SIGINT, SIGTERM: stop within a piece */
  options.error_fn = on_error;
  options.user = &run;
  /* The candidate list is held whole when it takes at most a sixteenth of the budget;
   * a longer one is searched again, a block at a time, while it is bounded. */
  options.candidate_memory = (size_t)(memory.mb * 1048576.0 / 16);
  bbc_chain_choice choice;
  memset(&choice, 0, sizeof choice);
  if (!chains_given) {
    cli_progress_begin(&bar, "weighing two-bounce chains", progress);
    options.search_progress = on_search_progress;
    options.progress_user = &bar;
    run.phase = "while weighing the two-bounce chain types";
    const bbc_result r = bbc_precompute_choose_chains(
        scene, &options, double_budget * 60 * BBC_DOUBLE_PIECES_PER_SECOND, &choice);
    cli_progress_end(&bar);
    if (r != BBC_OK) {
      if (r == BBC_ERR_CANCELLED || cli_interrupted)
        fprintf(stderr, "bbc-precompute: interrupted%s\n", not_written(output));
      bbc_scene_free(scene);
      return r == BBC_ERR_CANCELLED || cli_interrupted ? 130 : 1;
    }
    if (choice.left_out) say_left_out(&choice, double_budget, options.params.beam_receivers);
    options.params.chains = choice.chains;
  }
  cli_progress_begin(&bar, "finding tuples", progress);
  options.search_progress = on_search_progress;
  options.progress = on_progress;
  options.progress_user = &bar;
  options.estimate_fn = on_estimate;
  run.bar = &bar;
  run.show_estimate = bar.enabled || stats || dry_run;
  run.dry_run = dry_run;
  run.ignore_estimate = ignore_estimate;
  run.shard_count = options.shard_count;
  run.phase = "while finding the candidate tuples";
  bbc_cache_builder *builder = NULL;
  bbc_precompute_stats st;
  bbc_result r = bbc_precompute(&builder, scene, &options, &st);
  cli_progress_end(&bar);
  if (run.refused || (dry_run && r == BBC_ERR_CANCELLED && !cli_interrupted)) {
    bbc_cache_builder_free(builder);
    bbc_scene_free(scene);
    return run.refused ? 1 : 0;
  }
  if (r == BBC_ERR_CANCELLED || cli_interrupted) {
    fprintf(stderr, "bbc-precompute: interrupted%s\n", not_written(output));
    bbc_cache_builder_free(builder);
    bbc_scene_free(scene);
    return 130;
  }
  if (r != BBC_OK) {
    bbc_scene_free(scene);
    return 1;
  }
  const char *empty = options.shard_count ? NULL : why_empty(scene, options.params.chains, &st);
  if (empty && choice.left_out && st.candidate_tuples == 0) {
    /* The default left every chain type with candidates to light tracing: an empty cache
     * is then the answer, not a mistake. */
    fprintf(stderr,
            "bbc-precompute: warning: %s: the cache holds no tuples: every chain type with "
            "candidates is left to bbc-render's light tracing (--double-budget)\n",
            scene_path);
  } else if (empty && !has_caster(scene)) {
    /* Nothing to cache is the right answer for a scene without mirrors or glass. */
    fprintf(stderr, "bbc-precompute: warning: %s: %s; the cache holds no tuples\n", scene_path,
            empty);
  } else if (empty && !allow_empty) {
    fprintf(stderr,
            "bbc-precompute: %s: the cache would hold no tuple: %s%s%s\n", scene_path, empty,
            not_written(output), output ? " (--allow-empty writes it)" : "");
    bbc_cache_builder_free(builder);
    bbc_scene_free(scene);
    return 1;
  } else if (empty) {
    fprintf(stderr, "bbc-precompute: warning: %s: %s; the cache holds no tuples\n", scene_path,
            empty);
  }
  budget_enter_writing(&memory);
  double w0 = cli_now();
  bbc_cache_write_options write_options;
  memset(&write_options, 0, sizeof write_options);
  write_options.error_fn = on_error;
  write_options.user = &run;
  run.phase = "while writing the cache";
  write_options.progress_fn = cli_poll_interrupt;
  write_options.omit_geometry = no_geometry;
  r = bbc_cache_builder_write(builder, output, &write_options);
  double write_seconds = cli_now() - w0;
  bbc_cache_builder_free(builder);
  bbc_scene_free(scene);
  if (cli_interrupted) {
    fprintf(stderr, "bbc-precompute: interrupted%s\n", not_written(output));
    return 130;
  }
  if (r != BBC_OK) return 1;

  struct stat file;
  long long file_size = stat(output, &file) == 0 ? (long long)file.st_size : -1;
  struct rusage usage_info;
  getrusage(RUSAGE_SELF, &usage_info);
  double peak_mb = usage_info.ru_maxrss / 1024.0;
  /* User + system time of the whole run, every thread and phase. */
  double process_cpu = (double)usage_info.ru_utime.tv_sec + 1e-6 * usage_info.ru_utime.tv_usec +
                       (double)usage_info.ru_stime.tv_sec + 1e-6 * usage_info.ru_stime.tv_usec;
  double total = cli_now() - start;
  double cpu = st.position_cpu_seconds + st.irradiance_cpu_seconds;
  double pos_share = cpu > 0 ? st.position_cpu_seconds / cpu : 0;
  double bound_total = st.bounding_seconds + st.recording_seconds;
  double tuples = st.tuples ? (double)st.tuples : 1;
  char shard_text[96] = "";
  if (options.shard_count)
    snprintf(shard_text, sizeof shard_text, "; shard %u/%u bounded %llu of the candidates",
             options.shard_index, options.shard_count,
             (unsigned long long)(st.candidate_tuples > options.shard_index
                                      ? (st.candidate_tuples - options.shard_index - 1) /
                                                options.shard_count +
                                            1
                                      : 0));
  /* Stored tuples per chain type: "R 12, TT 40" and the JSON fields "tuples_R" etc. */
  char per_chain[160] = "", json_chains[320] = "";
  for (int c = 0; c < BBC_CHAIN_COUNT; c++) {
    unsigned long long n = st.tuples_per_chain[c];
    const char *name = bbc_chain_name((bbc_chain)c);
    size_t used = strlen(json_chains);
    snprintf(json_chains + used, sizeof json_chains - used, "  \"tuples_%s\": %llu,\n", name, n);
    if (n == 0 && !(options.params.chains & BBC_CHAIN_BIT(c))) continue;
    used = strlen(per_chain);
    snprintf(per_chain + used, sizeof per_chain - used, "%s%s %llu", used ? ", " : "", name, n);
  }
  /* The budget, and the address-space limit that enforced it (or the user's, kept). */
  char budget_text[320], asked[96];
  if (memory.basis)
    snprintf(asked, sizeof asked, "default: 3/4 of %s", memory.basis);
  else
    snprintf(asked, sizeof asked, "--memory");
  if (memory.kept)
    snprintf(budget_text, sizeof budget_text,
             "%.0f MB: the address-space limit of %.0f MB (ulimit -v) was kept, lower than "
             "the %.0f MB asked (%s) plus %.0f MB for the program's own mappings",
             memory.mb, memory.limit_mb, memory.requested_mb, asked, memory.allowance_mb);
  else if (memory.limit_mb > 0)
    snprintf(budget_text, sizeof budget_text,
             "%.0f MB (%s); address space limited to %.0f MB: that plus %.0f MB for the "
             "program's own mappings (%.0f MB while writing)",
             memory.mb, asked, memory.limit_mb, memory.allowance_mb, memory.writing_mb);
  else
    snprintf(budget_text, sizeof budget_text, "%.0f MB (%s), not enforced", memory.mb, asked);
  if (stats) {
    fprintf(stderr,
            "time              %.3f s total: tuples %.3f s, bounding %.3f s (position %.0f%%, "
            "irradiance %.0f%%), recording %.3f s, writing %.3f s; %d threads\n"
            "share             position %.1f%%, irradiance %.1f%%, recording %.1f%% (of "
            "bounding + recording)\n"
            "tuples            %llu stored of %llu candidates (%s)%s\n"
            "second triangles  %.2f per first (two bounces, candidates)\n"
            "pieces per tuple  position %.2f, irradiance %.2f, kept %.2f\n"
            "grid entries      %llu (%u runs, %.1f MB spilled to a temporary file)\n"
            "file              %lld bytes (%.2f MB)\n"
            "memory budget     %s\n"
            "peak memory       %.1f MB\n",
            total, st.construction_seconds, st.bounding_seconds, 100 * pos_share,
            100 * (1 - pos_share), st.recording_seconds, write_seconds, st.threads,
            100 * pos_share * st.bounding_seconds / bound_total,
            100 * (1 - pos_share) * st.bounding_seconds / bound_total,
            100 * st.recording_seconds / bound_total, (unsigned long long)st.tuples,
            (unsigned long long)st.candidate_tuples, per_chain, shard_text, st.second_per_first,
            st.position_pieces / tuples, st.irradiance_pieces / tuples, st.kept_pieces / tuples,
            (unsigned long long)st.entries, st.spill_runs, st.spill_bytes / 1e6, file_size,
            file_size / 1e6, budget_text, peak_mb);
  }
  if (json) {
    FILE *f = fopen(json, "w");
    if (!f) cli_fail("%s: cannot write the statistics", json);
    fputs("{\n  \"scene\": ", f);
    json_string(f, scene_path);
    fprintf(f,
            ",\n  \"seconds\": %.6f,\n  \"tuple_seconds\": %.6f,\n"
            "  \"bounding_seconds\": %.6f,\n  \"position_cpu_seconds\": %.6f,\n"
            "  \"irradiance_cpu_seconds\": %.6f,\n  \"recording_seconds\": %.6f,\n"
            "  \"writing_seconds\": %.6f,\n  \"threads\": %d,\n  \"candidate_tuples\": %llu,\n"
            "  \"tuples\": %llu,\n%s  \"second_per_first\": %.4f,\n"
            "  \"position_pieces_per_tuple\": %.4f,\n  \"irradiance_pieces_per_tuple\": %.4f,\n"
            "  \"entries\": %llu,\n  \"spill_bytes\": %llu,\n  \"file_bytes\": %lld,\n"
            "  \"process_cpu_seconds\": %.3f,\n  \"memory_budget_mb\": %.1f,\n"
            "  \"memory_budget_source\": \"%s\",\n  \"memory_allowance_mb\": %.1f,\n"
            "  \"address_space_limit_mb\": %.1f,\n  \"peak_memory_mb\": %.1f,\n",
            total, st.construction_seconds, st.bounding_seconds, st.position_cpu_seconds,
            st.irradiance_cpu_seconds, st.recording_seconds, write_seconds, st.threads,
            (unsigned long long)st.candidate_tuples, (unsigned long long)st.tuples, json_chains,
            st.second_per_first, st.position_pieces / tuples, st.irradiance_pieces / tuples,
            (unsigned long long)st.entries, (unsigned long long)st.spill_bytes, file_size,
            process_cpu, memory.mb, memory.source, memory.allowance_mb, memory.limit_mb, peak_mb);
    /* The two-bounce chain types the default left out, as the probe weighed them. */
    fputs("  \"chains_left_out\": {", f);
    for (int c = 0, first = 1; c < BBC_CHAIN_COUNT; c++)
      if (choice.left_out & BBC_CHAIN_BIT(c)) {
        fprintf(f, "%s\"%s\": {\"candidates\": %llu, \"pieces\": %.0f}", first ? "" : ", ",
                bbc_chain_name((bbc_chain)c), (unsigned long long)choice.candidates[c],
                choice.pieces[c]);
        first = 0;
      }
    fputs("},\n", f);
    /* The estimate made before the bounding, beside what came true. */
    const bbc_precompute_estimate *e = &st.estimate;
    fputs("  \"estimate\": {\n", f);
    for (int c = 0; c < BBC_CHAIN_COUNT; c++)
      fprintf(f, "    \"candidates_%s\": %llu,\n", bbc_chain_name((bbc_chain)c),
              (unsigned long long)e->candidates_per_chain[c]);
    fprintf(f,
            "    \"candidate_tuples\": %llu,\n    \"bounded_tuples\": %llu,\n"
            "    \"list_bytes\": %llu,\n    \"list_held\": %s,\n    \"search_bytes\": %llu,\n"
            "    \"search_seconds\": %.6f,\n    \"sample_tuples\": %u,\n"
            "    \"sample_cpu_seconds\": %.6f,\n    \"stored_fraction\": %.4f,\n"
            "    \"entries_per_tuple\": %.2f,\n    \"bounding_cpu_seconds\": %.3f,\n"
            "    \"seconds\": %.3f,\n    \"stored_tuples\": %llu,\n"
            "    \"memory_bytes\": %llu,\n    \"file_bytes\": %llu\n  }\n}\n",
            (unsigned long long)e->candidate_tuples, (unsigned long long)e->bounded_tuples,
            (unsigned long long)e->list_bytes, e->list_held ? "true" : "false",
            (unsigned long long)e->search_bytes, e->search_seconds, e->sample_tuples,
            e->sample_cpu_seconds, e->stored_fraction, e->entries_per_tuple,
            e->bounding_cpu_seconds, e->seconds, (unsigned long long)e->stored_tuples,
            (unsigned long long)e->memory_bytes, (unsigned long long)e->file_bytes);
    if (fclose(f) != 0) cli_fail("%s: cannot write the statistics", json);
  }
  return 0;
}
