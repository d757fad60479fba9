/* replay: runs a fuzz target's LLVMFuzzerTestOneInput over files, without libFuzzer.
 *
 *   replay_cache PATH...     (likewise replay_scene)
 *
 * Each PATH is a file or a directory whose regular files (not recursively) are each
 * fed to the target once, in name order. This is how the corpora run as ordinary ctest
 * entries with any compiler (as zstd's regression driver does): a crash, a sanitizer
 * report or a broken contract (the target calls abort) fails the test. Exits 0 after
 * the last file, 1 when a path cannot be read or no file was found. */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static int run_file(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f) {
    fprintf(stderr, "replay: cannot open %s\n", path);
    return 1;
  }
  size_t cap = 1 << 16, size = 0;
  uint8_t *data = malloc(cap);
  size_t n;
  while (data && (n = fread(data + size, 1, cap - size, f)) > 0) {
    size += n;
    if (size == cap) {
      uint8_t *grown = realloc(data, cap *= 2);
      if (!grown) free(data);
      data = grown;
    }
  }
  int bad = !data || ferror(f);
  fclose(f);
  if (bad) {
    free(data);
    fprintf(stderr, "replay: cannot read %s\n", path);
    return 1;
  }
  /* An exact-size copy, so that AddressSanitizer sees any read past the input. */
  uint8_t *exact = malloc(size ? size : 1);
  if (!exact) {
    free(data);
    return 1;
  }
  memcpy(exact, data, size);
  free(data);
  LLVMFuzzerTestOneInput(exact, size);
  free(exact);
  return 0;
}

static int compare_names(const void *a, const void *b) {
  return strcmp(*(char *const *)a, *(char *const *)b);
}

/* Runs every regular file of dir; *files counts them. */
static int run_directory(const char *dir, int *files) {
  DIR *d = opendir(dir);
  if (!d) {
    fprintf(stderr, "replay: cannot open directory %s\n", dir);
    return 1;
  }
  char **names = NULL;
  size_t count = 0, cap = 0;
  int bad = 0;
  for (struct dirent *e; (e = readdir(d)) != NULL;) {
    if (e->d_name[0] == '.') continue;
    size_t len = strlen(dir) + strlen(e->d_name) + 2;
    char *path = malloc(len);
    if (!path) {
      bad = 1;
      break;
    }
    snprintf(path, len, "%s/%s", dir, e->d_name);
    struct stat st;
    if (stat(path, &st) != 0 || !S_ISREG(st.st_mode)) {
      free(path);
      continue;
    }
    if (count == cap) {
      char **grown = realloc(names, (cap = cap ? 2 * cap : 64) * sizeof *names);
      if (!grown) {
        free(path);
        bad = 1;
        break;
      }
      names = grown;
    }
    names[count++] = path;
  }
  closedir(d);
  if (count) qsort(names, count, sizeof *names, compare_names);
  for (size_t i = 0; i < count; i++) {
    if (!bad) {
      bad |= run_file(names[i]);
      ++*files;
    }
    free(names[i]);
  }
  free(names);
  return bad;
}

int main(int argc, char **argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: %s FILE_OR_DIRECTORY...\n", argv[0]);
    return 2;
  }
  int bad = 0, files = 0;
  for (int i = 1; i < argc; i++) {
    struct stat st;
    if (stat(argv[i], &st) != 0) {
      fprintf(stderr, "replay: cannot find %s\n", argv[i]);
      bad = 1;
    } else if (S_ISDIR(st.st_mode)) {
      bad |= run_directory(argv[i], &files);
    } else {
      bad |= run_file(argv[i]);
      files++;
    }
  }
  printf("replay: %d files\n", files);
  if (files == 0) {
    fprintf(stderr, "replay: no input files\n");
    return 1;
  }
  return bad;
}
