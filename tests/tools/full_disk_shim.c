/* full_disk_shim: an LD_PRELOAD library that makes the disk look full, for the tests of
 * what the tools do then (tests/cli/test_precompute.sh).
 *
 *   BBC_DISK_FULL_AFTER=N   fwrite to any stream but stdout/stderr fails with ENOSPC once
 *                           N bytes have been written in all (the write that crosses
 *                           the limit writes nothing)
 *   BBC_DISK_FREE=N         statvfs reports N free bytes (f_bavail * f_frsize)
 *
 * Test-only: not installed, not part of the product. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/statvfs.h>

__attribute__((visibility("default"))) size_t fwrite(const void *data, size_t size, size_t count, FILE *stream) {
  static size_t (*real)(const void *, size_t, size_t, FILE *);
  static long long left = -2;
  if (!real) real = (size_t(*)(const void *, size_t, size_t, FILE *))dlsym(RTLD_NEXT, "fwrite");
  if (left == -2) {
    const char *e = getenv("BBC_DISK_FULL_AFTER");
    left = e ? atoll(e) : -1;
  }
  if (left >= 0 && stream != stdout && stream != stderr) {
    long long want = (long long)(size * count);
    if (want > left) {
      left = 0;
      errno = ENOSPC;
      return 0;
    }
    left -= want;
  }
  return real(data, size, count, stream);
}

__attribute__((visibility("default"))) int statvfs(const char *path, struct statvfs *out) {
  static int (*real)(const char *, struct statvfs *);
  if (!real) real = (int (*)(const char *, struct statvfs *))dlsym(RTLD_NEXT, "statvfs");
  int r = real(path, out);
  const char *e = getenv("BBC_DISK_FREE");
  if (r == 0 && e) {
    out->f_frsize = 1;
    out->f_bavail = (fsblkcnt_t)atoll(e);
  }
  return r;
}
