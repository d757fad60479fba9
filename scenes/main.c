/* bbc-scenegen: writes the project's own demo and test scenes as glTF 2.0.
 *
 * The generator is deliberately standalone (C11 and libm only, no libbbc): the scenes
 * it writes are the inputs the library is tested on, so they must not be produced by
 * the code under test. It writes the glTF JSON and the binary buffer itself.
 *
 * Conventions every scene follows (the scene loader relies on them):
 *   - y is up; all geometry is written directly in world space, only the light and
 *     the camera nodes carry a transform.
 *   - asset.extras.bbc.light_units "radiometric": the light intensity is in W/sr.
 *   - Node extras {"bbc": {"role": "caster" | "receiver" | "none"}}.
 *   - Materials: diffuse = baseColor 0.8, metallic 0, roughness 1; mirror = baseColor
 *     1, metallic 1, roughness 0; glass/water = metallic 0, roughness 0 with
 *     KHR_materials_transmission 1, KHR_materials_volume thickness 1 and
 *     KHR_materials_ior.
 *   - Casters have smooth analytic vertex normals and shared vertices (the diamond:
 *     flat facets, each with vertices of its own); receivers have
 *     NORMAL and TEXCOORD_0 spanning [0,1]. Triangles wind counter-clockwise seen from
 *     the side their normals point to.
 *   - One point light (KHR_lights_punctual) or, with --area-light, one small emissive
 *     square of the same total power facing down, or with --sun / --spot a directional
 *     or spot light aimed from the light's position at the origin; one perspective
 *     camera whose node extras hold the image size.
 *
 * The output depends only on the arguments, so repeated runs give identical bytes. */
#define _POSIX_C_SOURCE 200809L

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Limits that keep every count, index and byte offset far inside 32 bits. */
#define MAX_SIZE 10000000ul
#define MAX_IMAGE_SIDE 65536ul
#define MAX_AREA_SIDE 100.0

#include "scenegen.h"

/* ------------------------------------------------------------------------------------ */
/* Failure handling. The tool exits on out-of-memory because there is nothing useful it
 * could do instead, and saying so is better than writing a truncated scene. */

void die_oom(void) {
  fprintf(stderr, TOOL ": out of memory\n");
  exit(1);
}

void *xrealloc(void *p, size_t n) {
  void *q = realloc(p, n ? n : 1);
  if (!q) die_oom();
  return q;
}

/* ------------------------------------------------------------------------------------ */
/* Command line. */

static void print_help(FILE *f) {
  fprintf(f,
          "bbc-scenegen: writes the bbc demo and test scenes as glTF 2.0.\n"
          "\n"
          "Usage:\n"
          "  " TOOL
          " KIND -o OUT.gltf [options]   writes OUT.gltf and OUT.bin\n"
          "  " TOOL
          " KIND -o OUT.glb --glb [options]\n"
          "\n"
          "Kinds (y is up; every scene has a diffuse floor as receiver):\n");
  for (int k = 0; k < KIND_COUNT; k++) fprintf(f, "  %-14s %s\n", KINDS[k].name, KINDS[k].summary);
  fprintf(f,
          "\n"
          "Output:\n"
          "  -o, --output PATH     the scene to write (through a temporary file)\n"
          "  --glb                 write one binary .glb instead of .gltf plus .bin\n"
          "\n"
          "Geometry:\n"
          "  --size N              about N caster triangles (default 2000; for floor, the\n"
          "                        floor's own triangles, default 2)\n"
          "\n"
          "Lighting:\n"
          "  --area-light SIDE     instead of the point light, an emissive square of side\n"
          "                        SIDE facing down, of the same total power\n"
          "  --sun E               instead of the point light, a directional light of\n"
          "                        irradiance E (W/m^2) travelling from the light's\n"
          "                        position toward the origin\n"
          "  --sun-angle DEG       with --sun, the sun's angular diameter in degrees\n"
          "                        (extras.bbc.angular_diameter; 0.53 for the real sun)\n"
          "  --spot OUTER          instead of the point light, a spot of the same intensity\n"
          "                        aimed at the origin, cone angles OUTER/2 and OUTER (rad)\n"
          "\n"
          "Camera:\n"
          "  --width W             image width stored with the camera (default 320)\n"
          "  --height H            image height (default 240); aspect ratio is W/H\n"
          "  --orbit N             animate the camera: N keys, one per frame at 24 fps,\n"
          "                        turning it 20 degrees about the vertical axis through\n"
          "                        its target; adds a static second camera \"side\"\n"
          "\n"
          "Receiver:\n"
          "  --floor-size N        the floor as a flat grid of about N triangles in the same\n"
          "                        plane (default: 2, one quad; the pool floor and the\n"
          "                        glass pool's floor too; not for floor)\n"
          "  --floor-bend H        bend that floor into one wave of height H in [0, 1] along\n"
          "                        x: a curved receiver, not a plane (default 0)\n"
          "  --checker N           a base colour texture: an N x N checker of sand and blue\n"
          "                        (sRGB PNG in the buffer, NEAREST, REPEAT), texel (0, 0)\n"
          "                        light, over TEXCOORD_0 in [0, 1]\n"
          "  --roughness R         roughnessFactor in [0, 1] (default 1)\n"
          "  --metallic M          metallicFactor in [0, 1] (default 0)\n"
          "\n"
          "Other:\n"
          "  -h, --help            show this help and exit\n"
          "  --version             print the version and exit\n"
          "\n"
          "Options take their value as --opt VALUE or --opt=VALUE. The same arguments\n"
          "always give the same bytes.\n");
}

static int usage_error(const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  fprintf(stderr, TOOL ": ");
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fprintf(
      stderr,
      "\nusage: " TOOL
      " KIND -o OUT.gltf [--size N] [--width W] [--height H]"
      " [--area-light SIDE | --sun E [--sun-angle DEG] | --spot OUTER] [--orbit N] [--checker N]"
      " [--roughness R] [--metallic M] [--floor-size N] [--glb]\n"
      "Try '" TOOL " --help' for the kinds and options.\n");
  return 2;
}

/* Strict unsigned integer: digits only (no sign, space or trailing junk), in range. */
static int parse_count(const char *s, unsigned long lo, unsigned long hi, unsigned long *out) {
  if (!isdigit((unsigned char)s[0])) return -1;
  char *end;
  errno = 0;
  unsigned long x = strtoul(s, &end, 10);
  if (errno || *end || x < lo || x > hi) return -1;
  *out = x;
  return 0;
}

/* Strict positive length: a plain decimal number, finite, no trailing junk. */
static int parse_length(const char *s, double hi, double *out) {
  if (!isdigit((unsigned char)s[0]) && s[0] != '.') return -1;
  char *end;
  errno = 0;
  double x = strtod(s, &end);
  if (errno || *end || !isfinite(x) || !(x > 0) || x > hi) return -1;
  *out = x;
  return 0;
}

/* Parses the command line; returns -1 to go on, or the exit status. */
static int parse_args(int argc, char **argv, options *o) {
  memset(o, 0, sizeof *o);
  o->kind = KIND_COUNT;
  o->width = 320, o->height = 240;
  o->roughness = 1;
  for (int i = 1; i < argc; i++) {
    const char *arg = argv[i];
    if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) {
      print_help(stdout);
      return 0;
    }
    if (strcmp(arg, "--version") == 0) {
      printf(TOOL " %s\n", BBC_VERSION);
      return 0;
    }
    if (arg[0] != '-' || arg[1] == '\0') {
      if (o->kind != KIND_COUNT) return usage_error("unexpected argument '%s'", arg);
      for (int k = 0; k < KIND_COUNT; k++)
        if (strcmp(arg, KINDS[k].name) == 0) o->kind = (kind)k;
      if (o->kind == KIND_COUNT) return usage_error("unknown kind '%s'", arg);
      continue;
    }
    /* Split --opt=value; otherwise the value, if the option takes one, is the next
     * argument. */
    char name[32];
    const char *value = NULL, *eq = strchr(arg, '=');
    size_t name_len = eq && arg[1] == '-' ? (size_t)(eq - arg) : strlen(arg);
    if (name_len >= sizeof name) return usage_error("unknown option '%s'", arg);
    memcpy(name, arg, name_len);
    name[name_len] = '\0';
    if (eq && arg[1] == '-') value = eq + 1;
    if (strcmp(name, "--glb") == 0) {
      if (value) return usage_error("option --glb takes no value");
      o->glb = 1;
      continue;
    }
    int known = strcmp(name, "-o") == 0 || strcmp(name, "--output") == 0 ||
                strcmp(name, "--size") == 0 || strcmp(name, "--width") == 0 ||
                strcmp(name, "--height") == 0 || strcmp(name, "--area-light") == 0 ||
                strcmp(name, "--sun") == 0 || strcmp(name, "--spot") == 0 ||
                strcmp(name, "--sun-angle") == 0 || strcmp(name, "--orbit") == 0 ||
                strcmp(name, "--checker") == 0 || strcmp(name, "--roughness") == 0 ||
                strcmp(name, "--metallic") == 0 || strcmp(name, "--floor-size") == 0 ||
                strcmp(name, "--floor-bend") == 0;
    if (!known) return usage_error("unknown option '%s'", arg);
    if (!value) {
      if (i + 1 >= argc) return usage_error("option %s needs a value", name);
      value = argv[++i];
    }
    if (strcmp(name, "-o") == 0 || strcmp(name, "--output") == 0) {
      if (!value[0]) return usage_error("the output path is empty");
      o->output = value;
    } else if (strcmp(name, "--size") == 0) {
      if (parse_count(value, 1, MAX_SIZE, &o->size))
        return usage_error("--size wants a whole number from 1 to %lu, not '%s'", MAX_SIZE, value);
      o->size_given = 1;
    } else if (strcmp(name, "--width") == 0 || strcmp(name, "--height") == 0) {
      unsigned long *dst = name[2] == 'w' ? &o->width : &o->height;
      if (parse_count(value, 1, MAX_IMAGE_SIDE, dst))
        return usage_error("%s wants a whole number from 1 to %lu, not '%s'", name, MAX_IMAGE_SIDE,
                           value);
    } else if (strcmp(name, "--sun") == 0) {
      if (parse_length(value, 1e9, &o->sun))
        return usage_error("--sun wants an irradiance above 0, not '%s'", value);
    } else if (strcmp(name, "--sun-angle") == 0) {
      if (parse_length(value, 20, &o->sun_angle))
        return usage_error("--sun-angle wants degrees above 0 and at most 20, not '%s'", value);
    } else if (strcmp(name, "--spot") == 0) {
      if (parse_length(value, 1.5707963267948966, &o->spot))
        return usage_error("--spot wants an outer cone angle in (0, pi/2], not '%s'", value);
    } else if (strcmp(name, "--checker") == 0) {
      if (parse_count(value, 1, 4096, &o->checker))
        return usage_error("--checker wants a whole number of squares from 1 to 4096, not '%s'",
                           value);
    } else if (strcmp(name, "--roughness") == 0 || strcmp(name, "--metallic") == 0 ||
               strcmp(name, "--floor-bend") == 0) {
      double *dst = name[2] == 'r' ? &o->roughness : name[2] == 'm' ? &o->metallic : &o->floor_bend;
      char *end;
      errno = 0;
      double x = strtod(value, &end);
      if (!(isdigit((unsigned char)value[0]) || value[0] == '.') || errno || *end ||
          !(x >= 0 && x <= 1))
        return usage_error("%s wants a number from 0 to 1, not '%s'", name, value);
      *dst = x;
    } else if (strcmp(name, "--floor-size") == 0) {
      if (parse_count(value, 2, MAX_SIZE, &o->floor_size))
        return usage_error("--floor-size wants a whole number from 2 to %lu, not '%s'", MAX_SIZE,
                           value);
    } else if (strcmp(name, "--orbit") == 0) {
      if (parse_count(value, 2, 10000, &o->orbit))
        return usage_error("--orbit wants a whole number of keys from 2 to 10000, not '%s'", value);
    } else {
      if (parse_length(value, MAX_AREA_SIDE, &o->area_side))
        return usage_error("--area-light wants a side length above 0 and at most %g, not '%s'",
                           MAX_AREA_SIDE, value);
    }
  }
  if (o->kind == KIND_COUNT) return usage_error("no scene kind given");
  if ((o->area_side > 0) + (o->sun > 0) + (o->spot > 0) > 1)
    return usage_error("--area-light, --sun and --spot each replace the point light: give one");
  if (o->sun_angle > 0 && !(o->sun > 0)) return usage_error("--sun-angle needs --sun");
  if ((o->floor_size || o->floor_bend > 0) && o->kind == KIND_FLOOR)
    return usage_error("--floor-size is for kinds with a caster; floor takes --size");
  if (!o->output) return usage_error("no output file given (-o OUT.gltf)");
  /* Loaders pick the parser by extension, so a name that says the other format would
   * make a file nothing can read back. */
  size_t n = strlen(o->output);
  if (o->glb && n >= 5 && strcmp(o->output + n - 5, ".gltf") == 0)
    return usage_error("--glb writes binary glTF, but the output ends in .gltf");
  if (!o->glb && n >= 4 && strcmp(o->output + n - 4, ".glb") == 0)
    return usage_error("the output ends in .glb; add --glb to write binary glTF");
  if (!o->size_given) o->size = KINDS[o->kind].default_size;
  return -1;
}

int main(int argc, char **argv) {
  options o;
  int rc = parse_args(argc, argv, &o);
  if (rc >= 0) return rc;
  scene s;
  build_scene(&s, &o);
  rc = write_scene(&s) == 0 ? 0 : 1;
  free_scene(&s);
  return rc;
}
