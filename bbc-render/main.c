/* bbc-render: renders a glTF scene to OpenEXR. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bbc/bbc.h"
#include "cli.h"

static const char usage[] =
    "usage: bbc-render SCENE.gltf -o OUT.exr [options]   (bbc-render --help for all)\n";

static const char help[] =
    "bbc-render: render a glTF scene to a linear RGB OpenEXR image.\n"
    "\n"
    "usage: bbc-render SCENE.gltf -o OUT.exr [options]\n"
    "\n"
    "Output:\n"
    "  -o, --output FILE     the EXR image to write (required); written to a temporary\n"
    "                        file, read back and compared with the rendered pixels, then\n"
    "                        renamed, so no partial or damaged image is left at FILE (nor\n"
    "                        the temporary file of a run killed while writing it)\n"
    "  --png FILE            also write an 8-bit sRGB PNG preview (tone mapped)\n"
    "  --write-partial       when interrupted (SIGINT, SIGTERM), write the EXR (and the\n"
    "                        PNG) of the passes completed so far instead of nothing;\n"
    "                        nothing is written if no pass completed\n"
    "  --exposure EV         scale the PNG preview by 2^EV before tone mapping (default 0)\n"
    "  --width N             image width in pixels (default: the camera's\n"
    "                        extras.bbc.width; with only one of width/height given,\n"
    "                        the other follows the camera's aspect ratio)\n"
    "  --height N            image height in pixels (default: extras.bbc.height)\n"
    "  --region X0,Y0,X1,Y1  render only the pixels X0 <= x < X1, Y0 <= y < Y1 (0,0 the\n"
    "                        top left); the image keeps its size, the other pixels are\n"
    "                        black, and each rendered pixel is bit-identical to the same\n"
    "                        pixel of a whole-image render with the same seed and spp\n"
    "\n"
    "Cameras (the scene, cache and ray-tracing structure are loaded once for all images):\n"
    "  --camera NAME|INDEX   the camera to render: its glTF name (the camera's, else its\n"
    "                        node's), or its index among the scene's camera nodes in\n"
    "                        depth-first order (default 0, the first)\n"
    "  --all-cameras         one image per camera, OUT.camN.exr for camera N\n"
    "  --frames A:B[:STEP]   the frames A, A+STEP, ... <= B of the camera's glTF\n"
    "                        animation, frame F at time F/fps seconds, into OUT.FFFF.exr\n"
    "                        (OUT.camN.FFFF.exr with --all-cameras; the same for --png).\n"
    "                        Frame F uses a seed that is a fixed function of --seed and F,\n"
    "                        so re-rendering gives bit-identical frames\n"
    "  --fps F               frames per second of --frames (default 24, Blender's)\n"
    "  --shard I/N           render only this task's share of the images asked for: those\n"
    "                        whose position in the list (each camera's frames in turn,\n"
    "                        from 0) is I modulo N (0 <= I < N); each is bit-identical to\n"
    "                        the same image of the whole list, and a task whose share is\n"
    "                        empty writes nothing and exits 0\n"
    "  --shard auto[/N]      I/N from the job scheduler, as bbc-precompute --shard auto: I\n"
    "                        is SLURM_ARRAY_TASK_ID or JOB_COMPLETION_INDEX, N is given,\n"
    "                        else BBC_SHARD_COUNT, else the Slurm array's task count\n"
    "\n"
    "Scene:\n"
    "  --light-units U       photometric or radiometric: how light intensities are read\n"
    "                        (default: the file's asset.extras.bbc.light_units, else\n"
    "                        photometric, as glTF says: candela and lux, / 683 lm/W)\n"
    "\n"
    "Caustics (point lights through mirrors and glass, from a bbc-precompute cache):\n"
    "  --cache FILE          the .bbc cache of this scene; refused if it was computed\n"
    "                        for another scene or is a shard (bbc-precompute --shard);\n"
    "                        every chunk is checked (checksums, decoding, cell lists)\n"
    "                        before the first pixel, and a damaged cache is refused\n"
    "                        with exit status 1 and nothing written\n"
    "  --no-verify           check each chunk only when a lookup first needs it (a\n"
    "                        damaged one still stops the render, writing nothing)\n"
    "  --method NAME         bbc: sample tuples by their irradiance bounds (default with\n"
    "                        --cache); enumerate: every tuple covering the point (the\n"
    "                        deterministic reference); uniform: as many tuples on average\n"
    "                        as bbc, uniformly; one-sample: one tuple proportional to\n"
    "                        its bound (Eq. 23); pt: path tracing only (default without\n"
    "                        --cache; misses point-light caustics)\n"
    "  --gamma G             P = min(G * bound, 1) per tuple (default 300 for one\n"
    "                        specular vertex, 100 for two)\n"
    "  --expected-tuples W   instead, choose gamma per cell so that W tuples with a\n"
    "                        finite bound are expected (tuples whose bound is\n"
    "                        infinite are always taken)\n"
    "  --variance V          instead, choose gamma per cell so that the variance bound\n"
    "                        of Eq. 25 is V\n"
    "  --chains LIST         chain types used, comma-separated (R, T, RR, RT, TR, TT;\n"
    "                        default all)\n"
    "  --solver NAME         how double-scattering tuples (RR, RT, TR, TT) are solved, by\n"
    "                        Newton's method on the chain: newton-stoch (default): one\n"
    "                        start drawn on T1, its solution weighted by the number of\n"
    "                        further draws until one finds it again, an unbiased\n"
    "                        reciprocal-probability estimate; newton-det: one start at\n"
    "                        T1's centre, no variance but biased (misses solutions).\n"
    "                        Single scattering always uses the specular polynomials.\n"
    "  --light-trace on|off  light tracing of caustic paths (default on with --cache):\n"
    "                        photons from point, spot and delta-sun lights through the\n"
    "                        casters to points the camera sees directly; it counts the\n"
    "                        chains of 3+ specular vertices (and kinds the cache lacks)\n"
    "                        and, in the cells --light-trace-cells picks, the cached\n"
    "                        chain types, which the estimator then leaves out there;\n"
    "                        without a cache (off by default), 'on' light-traces every\n"
    "                        caustic path of those lights, of any length\n"
    "  --light-trace-cells B inf (default): cells with a tuple whose bound is infinite;\n"
    "                        a number: a bound at least B (per unit intensity, as\n"
    "                        bbc-inspect shows it); all: every cell; none: no cell\n"
    "  --photons N           photons per sample from the cones toward the casters\n"
    "                        (default: the image's pixel count, one per pixel per\n"
    "                        sample, with --region too; a sixteenth when only chains\n"
    "                        of 3+ mirrors can be light-traced)\n"
    "  --aimed-photons N|off photons per sample aimed at the first specular triangles\n"
    "                        of the tuples in the light-traced cells (default: as\n"
    "                        many, then down to an eighth after the first sample when\n"
    "                        few of them reach a pixel); off: none, the cones'\n"
    "                        photons take those paths too\n"
    "  --only PARTS          render only these parts, comma-separated: caustics (the\n"
    "                        caustic estimator and light tracing), seen-caustics (the\n"
    "                        caustics where the camera sees them directly, no specular\n"
    "                        surface between: what a light tracer renders), direct\n"
    "                        (light before any diffuse bounce), indirect (the rest)\n"
    "\n"
    "Measuring:\n"
    "  --reference FILE      print the relMSE against this EXR (same size; with\n"
    "                        --region, over the region's pixels)\n"
    "  --relmse-eps E        the eps of relMSE (default 1e-2)\n"
    "  --reject-outliers     leave the worst 0.1 % of pixels out of relMSE\n"
    "\n"
    "Path tracing:\n"
    "  --max-depth N         maximum number of path segments (default 16)\n"
    "  --no-fresnel          glass always transmits (reflects only under total internal\n"
    "                        reflection), as the paper assumes\n"
    "\n"
    "Budget (whichever is reached first; default 16 spp):\n"
    "  --spp N               samples per pixel (powers of two stratify best; any count\n"
    "                        works)\n"
    "  --time SECONDS        render for this long\n"
    "  --sampler NAME        sobol (default): per pixel, Owen-scrambled Sobol points for\n"
    "                        the film position, bounces, area-light points, Russian\n"
    "                        roulette and the first tuple bins; independent: independent\n"
    "                        random numbers\n"
    "\n"
    "Execution:\n"
    "  --threads N           worker threads (default: every core); the image does not\n"
    "                        depend on it\n"
    "  --seed K              random seed (default 0)\n"
    "  --progress            show a progress bar (default: when stderr is a terminal)\n"
    "  --no-progress         never show one\n"
    "  --stats               print time, samples, rays per second and the caustic\n"
    "                        estimator's figures (the paper's Table 2) to stderr\n"
    "  --version             print versions and exit\n"
    "  -h, --help            print this help and exit\n"
    "\n"
    "Units: point lights give KHR_lights_punctual intensity x color in candela, divided\n"
    "by 683 lm/W (or in W/sr with light units radiometric); emissive triangles give\n"
    "emissiveFactor x emissive_strength as radiance (W/sr/m^2). The EXR holds the mean radiance "
    "per pixel (box filter).\n"
    "Interrupting (SIGINT, SIGTERM) stops after the current pass.\n"
    "Exit status: 0 on success, 1 on a runtime failure (bad file, I/O), 2 on bad usage,\n"
    "130 when interrupted (nothing is written, or with --write-partial the partial image).\n";

/* Set by SIGINT and SIGTERM; the progress callback then cancels the render after the
 * current pass, as in bbc-precompute. */
typedef struct progress_state {
  cli_progress bar;
  double time_limit;
} progress_state;

static int on_progress(void *user, uint64_t done, uint64_t total) {
  progress_state *state = user;
  char detail[64];
  double fraction;
  if (total) {
    fraction = (double)done / (double)total;
    snprintf(detail, sizeof detail, "%llu/%llu spp", (unsigned long long)done,
             (unsigned long long)total);
  } else {
    fraction = (cli_now() - state->bar.start) / state->time_limit;
    snprintf(detail, sizeof detail, "%llu spp", (unsigned long long)done);
  }
  cli_progress_update(&state->bar, fraction, detail);
  return cli_interrupted;
}

static void print_stats(const bbc_render_stats *s, const bbc_render_options *options,
                        const bbc_scene *scene, long long width, long long height) {
  double rays_per_s = s->seconds > 0 ? s->rays / s->seconds : 0;
  fprintf(stderr,
          "time         %.3f s\n"
          "image        %lldx%lld, %u spp, %llu samples\n"
          "rays         %llu (%.3g Mrays/s, %.3g Mrays/s per thread, %d threads)\n",
          s->seconds, width, height, s->spp, (unsigned long long)s->samples,
          (unsigned long long)s->rays, rays_per_s * 1e-6,
          s->threads ? rays_per_s * 1e-6 / s->threads : 0.0, s->threads);
  if (options->light_trace)
    fprintf(stderr, "photons      %llu traced, %llu added to a pixel\n",
            (unsigned long long)s->photons, (unsigned long long)s->photon_splats);
  if (options->method != BBC_METHOD_PT) {
    double lookups = s->lookups ? (double)s->lookups : 1;
    double busy = s->thread_seconds > 0 ? s->thread_seconds : 1;
    fprintf(stderr,
            "caustics     %llu lookups; mean |U| %.2f, |B| %.2f, |S| %.2f; %.3f solutions "
            "per sampled tuple, %.3f per solved tuple (%.1f%% excluded by the pre-test)\n"
            "time shares  sampling %.1f%%, decoding %.1f%%, solving %.1f%%\n",
            (unsigned long long)s->lookups, s->candidates / lookups, s->bins / lookups,
            s->sampled / lookups, s->sampled ? (double)s->solutions / s->sampled : 0.0,
            s->sampled > s->excluded ? (double)s->solutions / (s->sampled - s->excluded) : 0.0,
            s->sampled ? 100.0 * s->excluded / s->sampled : 0.0,
            100 * s->sampling_seconds / busy, 100 * s->decoding_seconds / busy,
            100 * s->solving_seconds / busy);
    if (options->cache) {
      bbc_cache_info info;
      bbc_cache_get_info(options->cache, &info);
      fprintf(stderr, "tuples       %u in the cache, per light:\n", info.tuple_count);
      cli_print_tuples_per_light(stderr, "  ", bbc_cache_tuples(options->cache), info.tuple_count,
                                 info.scene_light_count + info.scene_emitter_count, scene);
    }
    if (s->newton_solves) {
      /* Double-scattering tuples: Newton's method on the chain (--solver). */
      unsigned cap =
          options->newton_max_trials ? options->newton_max_trials : BBC_NEWTON_MAX_TRIALS_DEFAULT;
      double mean_k = s->newton_estimates ? (double)s->newton_trials / s->newton_estimates : 0.0;
      fprintf(stderr,
              "newton       %s: %llu solves, %llu converged (%.1f%%); %llu estimates, mean K "
              "%.3f, %llu capped at K = %u\n",
              options->solver == BBC_SOLVER_NEWTON_DET ? "newton-det" : "newton-stoch",
              (unsigned long long)s->newton_solves, (unsigned long long)s->newton_converged,
              100.0 * s->newton_converged / s->newton_solves,
              (unsigned long long)s->newton_estimates, mean_k,
              (unsigned long long)s->newton_cap_hits, cap);
    }
  }
}

/* --frames A:B[:STEP]: integers 0 <= A <= B, STEP >= 1; anything else is a usage error. */
static void parse_frames(const cli_args *a, const char *text, long long *first, long long *last,
                         long long *step) {
  char buffer[128];
  snprintf(buffer, sizeof buffer, "%s", text);
  char *parts[3] = {buffer, NULL, NULL};
  int n = 1;
  for (char *c = buffer; *c && n <= 3; c++)
    if (*c == ':') {
      *c = '\0';
      if (n < 3) parts[n] = c + 1;
      n++;
    }
  if (n < 2 || n > 3) cli_usage_error(a->usage, "--frames: '%s' is not A:B or A:B:STEP", text);
  *first = cli_parse_int(a, "--frames", parts[0], 0, 100000000);
  *last = cli_parse_int(a, "--frames", parts[1], 0, 100000000);
  *step = n == 3 ? cli_parse_int(a, "--frames", parts[2], 1, 100000000) : 1;
  if (*last < *first) cli_usage_error(a->usage, "--frames: '%s': B is before A", text);
}

/* --region X0,Y0,X1,Y1: four integers with X0 < X1 and Y0 < Y1 (the image size is
 * checked once it is known). */
static void parse_region(const cli_args *a, const char *text, uint32_t region[4]) {
  char buffer[128];
  snprintf(buffer, sizeof buffer, "%s", text);
  char *parts[4] = {buffer, NULL, NULL, NULL};
  int n = 1;
  for (char *c = buffer; *c; c++)
    if (*c == ',') {
      *c = '\0';
      if (n < 4) parts[n] = c + 1;
      n++;
    }
  if (n != 4) cli_usage_error(a->usage, "--region: '%s' is not X0,Y0,X1,Y1", text);
  for (int i = 0; i < 4; i++) region[i] = (uint32_t)cli_parse_int(a, "--region", parts[i], 0, 16384);
  if (region[2] <= region[0] || region[3] <= region[1])
    cli_usage_error(a->usage, "--region: '%s' is empty (X1 <= X0 or Y1 <= Y0)", text);
}

/* The pixels of region {x0, y0, x1, y1} of image, as a new image (NULL on failure). */
static bbc_image *crop(const bbc_image *image, const uint32_t region[4]) {
  bbc_image *out = NULL;
  if (bbc_image_create(&out, region[2] - region[0], region[3] - region[1]) != BBC_OK) return NULL;
  for (uint32_t y = region[1]; y < region[3]; y++)
    memcpy(out->rgb + 3 * (size_t)(y - region[1]) * out->width,
           image->rgb + 3 * ((size_t)y * image->width + region[0]), 3 * sizeof(float) * out->width);
  return out;
}

/* The camera named `text`, else the one with that index; -1 if none. */
static long long find_camera(const bbc_scene *scene, const char *text) {
  for (uint32_t i = 0; i < scene->camera_count; i++)
    if (strcmp(scene->cameras[i].name, text) == 0) return i;
  char *end = NULL;
  long long index = strtoll(text, &end, 10);
  if (*text >= '0' && *text <= '9' && *end == '\0' && index < scene->camera_count) return index;
  return -1;
}

/* PATH with ".camN" and ".FFFF" inserted before its extension, for the cameras and
 * frames (negative: none). */
static void image_name(char *out, size_t size, const char *path, long long camera,
                       long long frame) {
  const char *slash = strrchr(path, '/'), *dot = strrchr(path, '.');
  size_t stem = dot && (!slash || dot > slash) ? (size_t)(dot - path) : strlen(path);
  char tags[64] = "";
  if (camera >= 0) snprintf(tags, sizeof tags, ".cam%lld", camera);
  if (frame >= 0) snprintf(tags + strlen(tags), sizeof tags - strlen(tags), ".%04lld", frame);
  snprintf(out, size, "%.*s%s%s", (int)stem, path, tags, path + stem);
}

/* The seed of frame f: a fixed mix of the base seed and f (SplitMix64's finaliser), so
 * frames differ in their noise and re-rendering a frame repeats it exactly. */
static uint64_t frame_seed(uint64_t seed, long long frame) {
  uint64_t z = seed + 0x9E3779B97F4A7C15ull * (uint64_t)(frame + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

/* Writes image to path through a temporary file beside it, which is read back and
 * compared with the image bit for bit before it is renamed: a task rerun after a
 * failure finds either a whole, verified image at path or none. 0, or -1 after one line
 * on stderr. */
static int write_exr_verified(const bbc_image *image, const char *path) {
  char tmp[1300];
  snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid());
  if (bbc_image_write_exr(image, tmp, cli_print_message, NULL) != BBC_OK) {
    remove(tmp);
    return -1;
  }
  bbc_image *back = NULL;
  int same = bbc_image_read_exr(&back, tmp, cli_print_message, NULL) == BBC_OK &&
             back->width == image->width && back->height == image->height &&
             memcmp(back->rgb, image->rgb, 3 * sizeof(float) * image->width * image->height) == 0;
  bbc_image_free(back);
  if (!same) {
    fprintf(stderr,
            "bbc-render: %s: the file written does not read back as the image rendered; "
            "not written\n",
            path);
    remove(tmp);
    return -1;
  }
  if (rename(tmp, path) != 0) {
    fprintf(stderr, "bbc-render: %s: cannot rename %s: %s\n", path, tmp, strerror(errno));
    remove(tmp);
    return -1;
  }
  return 0;
}

/* Renders one image of options->camera and writes it (and its PNG); returns the exit
 * status: 0, 1 on failure, 130 when interrupted. */
static int render_one(const bbc_scene *scene, const bbc_accel *accel,
                      const bbc_render_options *options, long long width, long long height,
                      const char *output, const char *png, double exposure,
                      const char *reference_path, double relmse_eps, double reject, int progress,
                      int stats, int write_partial) {
  int status = 1;
  bbc_image *image = NULL, *reference = NULL;
  if (reference_path) {
    if (bbc_image_read_exr(&reference, reference_path, cli_print_message, NULL) != BBC_OK)
      goto done;
    if (reference->width != (uint32_t)width || reference->height != (uint32_t)height) {
      fprintf(stderr, "bbc-render: %s: not the size of the image (%ux%u vs %lldx%lld)\n",
              reference_path, reference->width, reference->height, width, height);
      goto done;
    }
  }
  if (bbc_image_create(&image, (uint32_t)width, (uint32_t)height) != BBC_OK) {
    fprintf(stderr, "bbc-render: cannot allocate a %lldx%lld image\n", width, height);
    goto done;
  }

  progress_state state;
  state.time_limit = options->time_limit;
  cli_progress_begin(&state.bar, "rendering", progress);
  bbc_render_options opts = *options;
  opts.progress = on_progress;
  opts.progress_user = &state;
  bbc_render_stats render_stats;
  memset(&render_stats, 0, sizeof render_stats);
  /* A signal during loading cancels before the first pass (0 spp). */
  bbc_result r = cli_interrupted ? BBC_ERR_CANCELLED
                                 : bbc_render(scene, accel, &opts, image, &render_stats);
  cli_progress_end(&state.bar);
  /* A damaged chunk (already reported in one line by the cache) ends the render with
   * nothing written, even with --write-partial. */
  if (r == BBC_ERR_CHECKSUM || r == BBC_ERR_CORRUPT) goto done;
  if (r == BBC_ERR_CANCELLED || cli_interrupted) {
    /* Only the passes completed before the signal are in the image; write them only
     * when asked, and never an image of no pass at all. */
    if (!write_partial || render_stats.spp == 0) {
      fprintf(stderr, "bbc-render: interrupted; %s was not written\n", output);
      status = 130;
      goto done;
    }
    if (write_exr_verified(image, output) != 0) goto done;
    if (png && bbc_image_write_png(image, png, exposure, 1, cli_print_message, NULL) != BBC_OK)
      goto done;
    if (stats) print_stats(&render_stats, options, scene, width, height);
    fprintf(stderr, "bbc-render: interrupted after %u spp; wrote partial image %s\n",
            render_stats.spp, output);
    status = 130;
    goto done;
  }
  if (r != BBC_OK) {
    fprintf(stderr, "bbc-render: rendering failed: %s\n", bbc_result_string(r));
    goto done;
  }
  if (write_exr_verified(image, output) != 0) goto done;
  if (png && bbc_image_write_png(image, png, exposure, 1, cli_print_message, NULL) != BBC_OK)
    goto done;
  if (reference) {
    double relmse;
    const uint32_t *region = options->region;
    if (region[2]) {
      bbc_image *a = crop(image, region), *b = crop(reference, region);
      bbc_result rr = a && b ? bbc_image_relmse(a, b, relmse_eps, reject, &relmse)
                             : BBC_ERR_OUT_OF_MEMORY;
      bbc_image_free(a);
      bbc_image_free(b);
      if (rr != BBC_OK) goto done;
    } else if (bbc_image_relmse(image, reference, relmse_eps, reject, &relmse) != BBC_OK) {
      goto done;
    }
    printf("relMSE %.6g\n", relmse);
  }
  if (stats) print_stats(&render_stats, options, scene, width, height);
  status = 0;
done:
  bbc_image_free(image);
  bbc_image_free(reference);
  return status;
}

int main(int argc, char **argv) {
  cli_tool = "bbc-render";
  cli_args a = {argc, argv, 1, usage};
  const char *scene_path = NULL, *output = NULL, *png = NULL, *value = NULL;
  const char *cache_path = NULL, *reference_path = NULL;
  double relmse_eps = 1e-2, reject = 0;
  int method_given = 0;
  bbc_render_options options;
  memset(&options, 0, sizeof options);
  double exposure = 0;
  long long width = 0, height = 0;
  int progress = -1, stats = 0, write_partial = 0, verify = 1;
  int light_trace = -1, cells_none = 0; /* -1: the default, on with a cache */
  const char *camera_arg = NULL, *frames_arg = NULL;
  uint32_t shard_index = 0, shard_count = 0; /* --shard; count 0: every image */
  int all_cameras = 0;
  double fps = 24.0;
  bbc_light_units light_units = BBC_LIGHT_UNITS_FILE;

  while (a.i < argc) {
    const char *arg = argv[a.i];
    if (cli_flag(&a, "-h") || cli_flag(&a, "--help")) {
      fputs(help, stdout);
      return 0;
    } else if (cli_flag(&a, "--version")) {
      printf("bbc-render %s (libbbc %s, .bbc format %d.%d)\n", bbc_version_string(),
             bbc_version_string(), BBC_FORMAT_VERSION_MAJOR, BBC_FORMAT_VERSION_MINOR);
      return 0;
    } else if (cli_option(&a, "-o", &value) || cli_option(&a, "--output", &value)) {
      output = value;
    } else if (cli_option(&a, "--png", &value)) {
      png = value;
    } else if (cli_option(&a, "--exposure", &value)) {
      exposure = cli_parse_double(&a, "--exposure", value, -64, 64);
    } else if (cli_option(&a, "--width", &value)) {
      width = cli_parse_int(&a, "--width", value, 1, 16384);
    } else if (cli_option(&a, "--height", &value)) {
      height = cli_parse_int(&a, "--height", value, 1, 16384);
    } else if (cli_option(&a, "--region", &value)) {
      parse_region(&a, value, options.region);
    } else if (cli_option(&a, "--camera", &value)) {
      camera_arg = value;
    } else if (cli_flag(&a, "--all-cameras")) {
      all_cameras = 1;
    } else if (cli_option(&a, "--frames", &value)) {
      frames_arg = value;
    } else if (cli_option(&a, "--shard", &value)) {
      cli_parse_shard(&a, value, &shard_index, &shard_count);
    } else if (cli_option(&a, "--fps", &value)) {
      fps = cli_parse_double(&a, "--fps", value, 1e-3, 1e6);
    } else if (cli_option(&a, "--light-units", &value)) {
      light_units = cli_parse_light_units(&a, "--light-units", value);
    } else if (cli_option(&a, "--method", &value)) {
      static const char *names[] = {"pt", "bbc", "enumerate", "uniform", "one-sample"};
      int found = -1;
      for (int i = 0; i < 5; i++)
        if (strcmp(value, names[i]) == 0) found = i;
      if (found < 0)
        cli_usage_error(usage,
                        "--method: unknown method '%s' (bbc, enumerate, uniform, one-sample, pt)",
                        value);
      options.method = (bbc_method)found;
      method_given = 1;
    } else if (cli_option(&a, "--cache", &value)) {
      cache_path = value;
    } else if (cli_flag(&a, "--no-verify")) {
      verify = 0;
    } else if (cli_option(&a, "--gamma", &value)) {
      options.gamma_mode = BBC_GAMMA_FIXED;
      options.gamma_value = cli_parse_double(&a, "--gamma", value, 1e-300, 1e300);
    } else if (cli_option(&a, "--expected-tuples", &value)) {
      options.gamma_mode = BBC_GAMMA_EXPECTED;
      options.gamma_value = cli_parse_double(&a, "--expected-tuples", value, 1e-6, 1e9);
    } else if (cli_option(&a, "--variance", &value)) {
      options.gamma_mode = BBC_GAMMA_VARIANCE;
      options.gamma_value = cli_parse_double(&a, "--variance", value, 1e-300, 1e300);
    } else if (cli_option(&a, "--chains", &value)) {
      options.chains = cli_parse_chains(&a, "--chains", value);
    } else if (cli_option(&a, "--solver", &value)) {
      if (strcmp(value, "newton-stoch") == 0)
        options.solver = BBC_SOLVER_NEWTON_STOCH;
      else if (strcmp(value, "newton-det") == 0)
        options.solver = BBC_SOLVER_NEWTON_DET;
      else
        cli_usage_error(usage, "--solver: unknown solver '%s' (newton-stoch, newton-det)", value);
    } else if (cli_option(&a, "--sampler", &value)) {
      if (strcmp(value, "sobol") == 0)
        options.sampler = BBC_SAMPLER_SOBOL;
      else if (strcmp(value, "independent") == 0)
        options.sampler = BBC_SAMPLER_INDEPENDENT;
      else
        cli_usage_error(usage, "--sampler: unknown sampler '%s' (sobol, independent)", value);
    } else if (cli_option(&a, "--light-trace", &value)) {
      if (strcmp(value, "on") == 0)
        light_trace = 1;
      else if (strcmp(value, "off") == 0)
        light_trace = 0;
      else
        cli_usage_error(usage, "--light-trace: '%s' is neither on nor off", value);
    } else if (cli_option(&a, "--light-trace-cells", &value)) {
      if (strcmp(value, "inf") == 0)
        options.light_trace_bound = INFINITY;
      else if (strcmp(value, "all") == 0)
        options.light_trace_bound = -1;
      else if (strcmp(value, "none") == 0)
        cells_none = 1;
      else
        options.light_trace_bound = cli_parse_double(&a, "--light-trace-cells", value, 0, 1e300);
    } else if (cli_option(&a, "--photons", &value)) {
      options.photons_per_spp = (uint32_t)cli_parse_int(&a, "--photons", value, 1, 1u << 30);
    } else if (cli_option(&a, "--aimed-photons", &value)) {
      options.aimed_photons_per_spp =
          strcmp(value, "off") == 0
              ? BBC_AIMED_PHOTONS_OFF
              : (uint32_t)cli_parse_int(&a, "--aimed-photons", value, 1, 1u << 30);
    } else if (cli_option(&a, "--only", &value)) {
      options.components = 0;
      char buffer[256];
      snprintf(buffer, sizeof buffer, "%s", value);
      for (char *save = NULL, *name = strtok_r(buffer, ",", &save); name;
           name = strtok_r(NULL, ",", &save)) {
        if (strcmp(name, "caustics") == 0)
          options.components |= BBC_COMPONENT_CAUSTICS;
        else if (strcmp(name, "direct") == 0)
          options.components |= BBC_COMPONENT_DIRECT;
        else if (strcmp(name, "indirect") == 0)
          options.components |= BBC_COMPONENT_INDIRECT;
        else if (strcmp(name, "seen-caustics") == 0)
          options.components |= BBC_COMPONENT_SEEN_CAUSTICS;
        else
          cli_usage_error(
              usage, "--only: unknown part '%s' (caustics, seen-caustics, direct, indirect)", name);
      }
    } else if (cli_option(&a, "--reference", &value)) {
      reference_path = value;
    } else if (cli_option(&a, "--relmse-eps", &value)) {
      relmse_eps = cli_parse_double(&a, "--relmse-eps", value, 1e-300, 1e300);
    } else if (cli_flag(&a, "--reject-outliers")) {
      reject = 1e-3;
    } else if (cli_option(&a, "--max-depth", &value)) {
      options.max_depth = (uint32_t)cli_parse_int(&a, "--max-depth", value, 1, 1024);
    } else if (cli_flag(&a, "--no-fresnel")) {
      options.no_fresnel = 1;
    } else if (cli_option(&a, "--spp", &value)) {
      options.spp = (uint32_t)cli_parse_int(&a, "--spp", value, 1, 1 << 24);
    } else if (cli_option(&a, "--time", &value)) {
      options.time_limit = cli_parse_double(&a, "--time", value, 1e-3, 1e7);
    } else if (cli_option(&a, "--threads", &value)) {
      options.threads = (int)cli_parse_int(&a, "--threads", value, 1, 1024);
    } else if (cli_option(&a, "--seed", &value)) {
      options.seed = (uint64_t)cli_parse_int(&a, "--seed", value, 0, INT64_MAX);
    } else if (cli_flag(&a, "--progress")) {
      progress = 1;
    } else if (cli_flag(&a, "--no-progress")) {
      progress = 0;
    } else if (cli_flag(&a, "--stats")) {
      stats = 1;
    } else if (cli_flag(&a, "--write-partial")) {
      write_partial = 1;
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
  if (!output) cli_usage_error(usage, "no output given (-o OUT.exr)");
  if (!method_given) options.method = cache_path ? BBC_METHOD_BBC : BBC_METHOD_PT;
  /* Without a cache the path tracer renders alone, and light tracing, when asked for,
   * counts every caustic path of the point, spot and delta-sun lights. */
  options.light_trace = options.method == BBC_METHOD_PT ? light_trace == 1 : light_trace != 0;
  if (cells_none) options.light_trace_bound = NAN;
  if (options.method != BBC_METHOD_PT && !cache_path)
    cli_usage_error(usage, "--method %s needs a cache (--cache FILE.bbc from bbc-precompute)",
                    options.method == BBC_METHOD_BBC         ? "bbc"
                    : options.method == BBC_METHOD_ENUMERATE ? "enumerate"
                    : options.method == BBC_METHOD_UNIFORM   ? "uniform"
                                                             : "one-sample");

  if (camera_arg && all_cameras)
    cli_usage_error(usage, "--camera and --all-cameras exclude each other");
  long long frame_first = 0, frame_last = 0, frame_step = 1;
  if (frames_arg) parse_frames(&a, frames_arg, &frame_first, &frame_last, &frame_step);
  int several = all_cameras || frames_arg;
  if (several && reference_path)
    cli_usage_error(usage, "--reference compares one image; not with --all-cameras or --frames");

  cli_catch_interrupts();
  double load_start = cli_now();

  bbc_scene_options scene_options = {cli_print_message, cli_print_warning, NULL, light_units};
  bbc_scene *scene = NULL;
  if (bbc_scene_load(&scene, scene_path, &scene_options) != BBC_OK) return 1;

  /* The cameras to render, [first_camera, last_camera]. */
  uint32_t first_camera = 0, last_camera = all_cameras ? scene->camera_count - 1 : 0;
  if (camera_arg) {
    long long index = find_camera(scene, camera_arg);
    if (index < 0) {
      fprintf(stderr, "bbc-render: %s: --camera: no camera '%s' (%u cameras: ", scene_path,
              camera_arg, scene->camera_count);
      for (uint32_t i = 0; i < scene->camera_count && i < 8; i++)
        fprintf(stderr, "%s%u \"%s\"", i ? ", " : "", i, scene->cameras[i].name);
      fprintf(stderr, "%s)\n", scene->camera_count > 8 ? ", ..." : "");
      bbc_scene_free(scene);
      return 1;
    }
    first_camera = last_camera = (uint32_t)index;
  }
  if (frames_arg) {
    int animated = 0;
    for (uint32_t i = first_camera; i <= last_camera; i++) animated |= scene->cameras[i].animated;
    if (!animated) {
      fprintf(stderr,
              "bbc-render: %s: --frames: %s animated (no glTF animation channel moves %s node "
              "or its ancestors)\n",
              scene_path, all_cameras ? "no camera is" : "the camera is not",
              all_cameras ? "a camera's" : "its");
      bbc_scene_free(scene);
      return 1;
    }
  }

  /* --shard: this task's images are those whose position in the list is shard_index
   * modulo shard_count. When it has none, nothing is loaded further. */
  if (shard_count) {
    long long images = 0;
    for (uint32_t i = first_camera; i <= last_camera; i++)
      if (!frames_arg || scene->cameras[i].animated)
        images += frames_arg ? (frame_last - frame_first) / frame_step + 1 : 1;
    long long mine = images > shard_index ? (images - shard_index - 1) / shard_count + 1 : 0;
    if (mine == 0) {
      fprintf(stderr,
              "bbc-render: note: shard %u/%u: none of the %lld images asked for is "
              "this shard's; nothing to render\n",
              shard_index, shard_count, images);
      bbc_scene_free(scene);
      return 0;
    }
    if (stats)
      fprintf(stderr, "shard        %u/%u: %lld of the %lld images\n", shard_index, shard_count,
              mine, images);
  }

  bbc_accel *accel = NULL;
  bbc_cache *cache = NULL;
  int status = 1;
  long long position = 0; /* of the next image in the list, for --shard */
  if (cache_path && options.method != BBC_METHOD_PT) {
    bbc_cache_options cache_options;
    memset(&cache_options, 0, sizeof cache_options);
    cache_options.error_fn = cli_print_first_message;
    /* The chunks the validation decodes are kept for the render's threads, up to 256 MiB
     * of decoded lists (a cursor keeps up to 256 chunks of its own beyond that). */
    cache_options.keep_decoded = (size_t)256 << 20;
    if (bbc_cache_open(&cache, cache_path, &cache_options) != BBC_OK) goto done;
    if (verify && bbc_cache_validate(cache, cli_print_first_message, NULL) != BBC_OK) goto done;
    /* The cache reports what differs through its error callback, in one line; a scene
     * that differs by float noise only is given the cache's geometry. */
    if (cli_match_scene(cache, cache_path, scene) != 0) goto done;
    /* A shard holds only some of the tuples: its caustics would be missing the rest. */
    bbc_cache_shard shard;
    if (bbc_cache_get_shard(cache, &shard)) {
      fprintf(stderr,
              "bbc-render: %s: shard %u/%u of a sharded precompute holds only part of the "
              "tuples; merge the %u shards first (bbc-inspect merge OUT.bbc SHARD.bbc...)\n",
              cache_path, shard.index, shard.count, shard.count);
      goto done;
    }
    options.cache = cache;
    /* The cache bounds a delta sun: its caustics keep the sun's centre direction, while
     * the path tracer lights the rest with the disk (docs/lights.md). Said once. */
    for (uint32_t i = 0; i < scene->point_light_count; i++) {
      const bbc_light_model *m = &scene->point_lights[i].model;
      if (m->kind == BBC_LIGHT_DIRECTIONAL && m->angular_diameter > 0)
        fprintf(stderr,
                "bbc-render: note: cached caustics of sun %u use its centre direction (its "
                "angular diameter of %g degrees is ignored there)\n",
                i, m->angular_diameter * (180.0 / 3.14159265358979323846));
    }
  }
  if (bbc_accel_create(&accel, scene, cli_print_message, NULL) != BBC_OK) {
    fprintf(stderr, "bbc-render: %s: cannot build the ray-tracing structure\n", scene_path);
    goto done;
  }
  if (stats && several)
    fprintf(stderr, "loading      %.3f s (scene, cache and ray-tracing structure, once)\n",
            cli_now() - load_start);

  uint64_t base_seed = options.seed;
  for (uint32_t cam = first_camera; cam <= last_camera; cam++) {
    if (frames_arg && !scene->cameras[cam].animated) {
      fprintf(stderr, "bbc-render: warning: camera %u (\"%s\") is not animated; no frames for it\n",
              cam, scene->cameras[cam].name);
      continue;
    }
    for (long long frame = frame_first; frame <= frame_last; frame += frame_step) {
      if (shard_count && position++ % shard_count != shard_index) continue;
      bbc_camera camera;
      if (bbc_scene_camera_at(scene, cam, frames_arg ? (double)frame / fps : 0.0, &camera) !=
          BBC_OK) {
        fprintf(stderr, "bbc-render: %s: camera \"%s\" at frame %lld has a degenerate transform\n",
                scene_path, scene->cameras[cam].name, frame);
        goto done;
      }
      if (!frames_arg) camera = scene->cameras[cam];
      long long w = width, h = height;
      if (w && !h) h = (long long)(w / camera.aspect + 0.5);
      if (h && !w) w = (long long)(h * camera.aspect + 0.5);
      if (!w) w = camera.width;
      if (!h) h = camera.height;
      if (w < 1) w = 1;
      if (h < 1) h = 1;
      if (options.region[2] && (options.region[2] > w || options.region[3] > h))
        cli_usage_error(usage, "--region %u,%u,%u,%u does not lie within the %lldx%lld image",
                        options.region[0], options.region[1], options.region[2],
                        options.region[3], w, h);
      long long name_camera = all_cameras ? (long long)cam : -1;
      long long name_frame = frames_arg ? frame : -1;
      char out_name[1200], png_name[1200];
      image_name(out_name, sizeof out_name, output, name_camera, name_frame);
      if (png) image_name(png_name, sizeof png_name, png, name_camera, name_frame);
      /* What a run killed while writing these images left, a rerun removes. */
      cli_remove_leftovers(out_name);
      if (png) cli_remove_leftovers(png_name);
      if (frames_arg) options.seed = frame_seed(base_seed, frame);
      options.camera = &camera;
      if (stats && several) fprintf(stderr, "image        %s (camera %u \"%s\")\n", out_name, cam,
                                    camera.name);
      status = render_one(scene, accel, &options, w, h, out_name, png ? png_name : NULL, exposure,
                          reference_path, relmse_eps, reject, progress, stats, write_partial);
      if (status != 0) goto done;
      if (!frames_arg) break;
    }
  }
  status = 0;
done:
  bbc_cache_close(cache);
  bbc_accel_free(accel);
  bbc_scene_free(scene);
  return status;
}
