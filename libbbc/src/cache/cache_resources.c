/* Resource limits of a precompute, checked before anything large is allocated: the
 * least memory and file size a cache of the scene's receiver grids needs, whatever its
 * tuples, against the caller's memory budget (or the machine's physical memory) and the
 * output directory's free space. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <string.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include "bbc/cache.h"
#include "cache_format_internal.h"
#include "cache_shard_internal.h"
#include "report_internal.h"

/* "12.3 GiB", "4.5 MiB" or "1000 bytes". */
static const char *human(double bytes, char out[32]) {
  if (bytes >= 1073741824.0)
    snprintf(out, 32, "%.1f GiB", bytes / 1073741824.0);
  else if (bytes >= 1048576.0)
    snprintf(out, 32, "%.1f MiB", bytes / 1048576.0);
  else
    snprintf(out, 32, "%.0f bytes", bytes);
  return out;
}

/* Free bytes of the file system holding `path`'s directory, or -1 if unknown. */
static double free_bytes_beside(const char *path) {
  char dir[4096];
  snprintf(dir, sizeof dir, "%s", path);
  char *slash = strrchr(dir, '/');
  if (!slash)
    snprintf(dir, sizeof dir, ".");
  else if (slash == dir)
    dir[1] = '\0';
  else
    *slash = '\0';
  struct statvfs fs;
  if (statvfs(dir, &fs) != 0) return -1;
  return (double)fs.f_bavail * (double)fs.f_frsize;
}

bbc_result bbc_cache_check_resources(const bbc_scene *scene, const bbc_precompute_params *params,
                                     const char *output, uint64_t memory_budget,
                                     bbc_message_fn error_fn, void *user) {
  if (!scene || !params) return BBC_ERR_INVALID_ARGUMENT;
  bbc_grid *grid = NULL;
  bbc_result r = bbc_grid_create(&grid, scene, params->grid_resolution, error_fn, user);
  if (r != BBC_OK) return r;
  double cells = (double)grid->cell_count, triangles = (double)grid->uv_triangle_count;
  double receivers = grid->receiver_count;
  bbc_grid_free(grid);

  /* Memory: a list head per cell in the builder and the cell index the writer forms. */
  double per_cell = (double)bbc__cache_builder_cell_bytes() + BBC__CIDX_SIZE;
  double memory = cells * per_cell + triangles * BBC__TRUV_SIZE;
  long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  double physical = pages > 0 && page > 0 ? (double)pages * (double)page : -1;
  char a[32], b[32];
  if (memory_budget > 0 && memory > (double)memory_budget)
    return bbc__report(error_fn, user, BBC_ERR_OUT_OF_MEMORY,
                       "%s: %.0f cells at grid resolution %u need at least %s of memory "
                       "(%.0f bytes per cell before any entry), more than the memory budget "
                       "of %s: lower the resolution or raise the budget",
                       scene->path, cells, params->grid_resolution, human(memory, a), per_cell,
                       human((double)memory_budget, b));
  if (memory_budget == 0 && physical > 0 && memory > physical)
    return bbc__report(error_fn, user, BBC_ERR_OUT_OF_MEMORY,
                       "%s: %.0f cells at grid resolution %u need at least %s of memory "
                       "(%.0f bytes per cell before any entry); this machine has %s: "
                       "lower the resolution",
                       scene->path, cells, params->grid_resolution, human(memory, a), per_cell,
                       human(physical, b));

  /* Disk: every section but the cell lists, with headers and padding (spec Sec. 2). */
  double file = 64 + 32.0 * 10 + 80 * 10 + BBC__PARM_SIZE + BBC__FPRT_SIZE +
                receivers * BBC__RCVR_SIZE + triangles * BBC__TRUV_SIZE + cells * BBC__CIDX_SIZE;
  double available = output ? free_bytes_beside(output) : -1;
  if (available >= 0 && file > available)
    return bbc__report(error_fn, user, BBC_ERR_IO,
                       "%s: the cache of %.0f cells will be at least %s (its cell index "
                       "alone is %d bytes per cell) and its file system has %s free",
                       output, cells, human(file, a), (int)BBC__CIDX_SIZE, human(available, b));
  return BBC_OK;
}

bbc_result bbc_cache_merge_check_resources(const bbc_cache *const *shards, size_t n,
                                           const char *output, bbc_message_fn error_fn,
                                           void *user) {
  if (!shards || n == 0 || !shards[0]) return BBC_ERR_INVALID_ARGUMENT;
  /* The merged file repeats what every shard holds once (its grids, cell index and
   * geometry: the first shard's sections other than the lists, the tuples and SHRD)
   * and joins what they hold apart (their tuples, chunk records and compressed lists,
   * whose merged, recompressed size is about the sum). */
  double file = 0, lists = 0;
  for (size_t i = 0; i < n; i++) {
    if (!shards[i]) return BBC_ERR_INVALID_ARGUMENT;
    bbc_cache_info info;
    bbc_cache_get_info(shards[i], &info);
    for (uint32_t k = 0; k < info.section_count; k++) {
      bbc_cache_section s;
      bbc_cache_get_section(shards[i], k, &s);
      const int joined = s.type == BBC__SEC_TUPL || s.type == BBC__SEC_CDAT ||
                         s.type == BBC__SEC_CHNK;
      if (joined) file += (double)s.size;
      if (s.type == BBC__SEC_CDAT) lists += (double)s.size;
      if (!joined && s.type != BBC__SEC_SHRD && i == 0) file += (double)s.size + 64;
    }
  }
  bbc_cache_info first;
  bbc_cache_get_info(shards[0], &first);
  char a[32], b[32];
  /* Memory: the builder's list head per cell and the writer's cell index, as for a
   * precompute of the same grid. */
  double memory = (double)first.cell_count * ((double)bbc__cache_builder_cell_bytes() + BBC__CIDX_SIZE);
  long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  double physical = pages > 0 && page > 0 ? (double)pages * (double)page : -1;
  if (physical > 0 && memory > physical)
    return bbc__report(error_fn, user, BBC_ERR_OUT_OF_MEMORY,
                       "%s: merging %zu shards of %llu cells needs at least %s of memory; this "
                       "machine has %s",
                       output ? output : "(memory)", n, (unsigned long long)first.cell_count,
                       human(memory, a), human(physical, b));
  double available = output ? free_bytes_beside(output) : -1;
  if (available >= 0 && file > available)
    return bbc__report(error_fn, user, BBC_ERR_IO,
                       "%s: the merged cache will take about %s (%s of them the shards' "
                       "compressed cell lists) and its file system has %s free",
                       output, human(file, a), human(lists, b), human(available, (char[32]){0}));
  return BBC_OK;
}
