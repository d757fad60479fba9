/* The spill store (spill_internal.h): sorted runs of cell lists in an unlinked
 * temporary file, read back through a heap of runs ordered by their next cell. */
#define _POSIX_C_SOURCE 200809L
#include "spill_internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* On disk (native byte order: the file lives only as long as the process), each cell
 * of a run is a header and its entries. */
typedef struct cell_header {
  uint64_t cell;
  uint32_t count, reserved;
} cell_header;

#define WRITE_BUFFER (1u << 20)
#define READ_BUFFER (64u << 10)

typedef struct run {
  uint64_t begin, end;
} run;

struct bbc__spill {
  FILE *file;
  char *buffer; /* stdio's write buffer */
  uint64_t size;
  uint64_t run_begin;
  uint64_t last_cell; /* of the run being written, UINT64_MAX before its first cell */
  run *runs;
  uint32_t run_count, run_cap;
  char error[512];
};

static bbc_result fail(bbc__spill *s, const char *what, int err) {
  if (!s->error[0]) {
    const char *dir = getenv("TMPDIR");
    snprintf(s->error, sizeof s->error, "cannot %s the spill file in %s: %s", what,
             dir && *dir ? dir : "/tmp", strerror(err));
  }
  return BBC_ERR_IO;
}

bbc_result bbc__spill_create(bbc__spill **out) {
  *out = calloc(1, sizeof **out);
  if (!*out) return BBC_ERR_OUT_OF_MEMORY;
  (*out)->last_cell = UINT64_MAX;
  return BBC_OK;
}

void bbc__spill_free(bbc__spill *s) {
  if (!s) return;
  if (s->file) fclose(s->file);
  free(s->buffer);
  free(s->runs);
  free(s);
}

/* The file: made by mkstemp and unlinked at once, so it disappears with the process. */
static bbc_result open_file(bbc__spill *s) {
  const char *dir = getenv("TMPDIR");
  if (!dir || !*dir) dir = "/tmp";
  size_t len = strlen(dir) + sizeof "/bbc-spill-XXXXXX";
  char *path = malloc(len);
  s->buffer = malloc(WRITE_BUFFER);
  if (!path || !s->buffer) {
    free(path);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  snprintf(path, len, "%s/bbc-spill-XXXXXX", dir);
  int fd = mkstemp(path);
  if (fd < 0) {
    free(path);
    return fail(s, "create", errno);
  }
  unlink(path);
  free(path);
  s->file = fdopen(fd, "w+b");
  if (!s->file) {
    int err = errno;
    close(fd);
    return fail(s, "open", err);
  }
  setvbuf(s->file, s->buffer, _IOFBF, WRITE_BUFFER);
  return BBC_OK;
}

bbc_result bbc__spill_put(bbc__spill *s, uint64_t cell, const bbc__cell_entry *e, uint32_t n) {
  if (s->error[0]) return BBC_ERR_IO;
  if (n == 0 || (s->last_cell != UINT64_MAX && cell <= s->last_cell))
    return BBC_ERR_INVALID_ARGUMENT;
  if (!s->file) {
    bbc_result r = open_file(s);
    if (r != BBC_OK) return r;
  }
  cell_header h = {cell, n, 0};
  if (fwrite(&h, sizeof h, 1, s->file) != 1 || fwrite(e, sizeof *e, n, s->file) != n)
    return fail(s, "write", errno);
  s->size += sizeof h + sizeof *e * (uint64_t)n;
  s->last_cell = cell;
  return BBC_OK;
}

bbc_result bbc__spill_end_run(bbc__spill *s) {
  if (s->error[0]) return BBC_ERR_IO;
  if (s->size == s->run_begin) return BBC_OK; /* an empty run is none */
  /* Flushed here, so that a full disk is reported now and readers see every byte. */
  if (fflush(s->file) != 0) return fail(s, "write", errno);
  if (s->run_count == s->run_cap) {
    uint32_t cap = s->run_cap ? 2 * s->run_cap : 16;
    run *n = realloc(s->runs, sizeof *n * cap);
    if (!n) return BBC_ERR_OUT_OF_MEMORY;
    s->runs = n;
    s->run_cap = cap;
  }
  s->runs[s->run_count].begin = s->run_begin;
  s->runs[s->run_count].end = s->size;
  s->run_count++;
  s->run_begin = s->size;
  s->last_cell = UINT64_MAX;
  return BBC_OK;
}

uint32_t bbc__spill_run_count(const bbc__spill *s) {
  return s ? s->run_count : 0;
}

uint64_t bbc__spill_bytes(const bbc__spill *s) {
  return s ? s->size : 0;
}

const char *bbc__spill_error(const bbc__spill *s) {
  return s && s->error[0] ? s->error : NULL;
}

/* ------------------------------------------------------------------ reading */

typedef struct cursor {
  uint64_t pos, end; /* file bytes of the run not yet in the buffer */
  uint8_t *buf;
  size_t len, at, size;
  cell_header next; /* next.cell is UINT64_MAX once the run is read */
} cursor;

struct bbc__spill_reader {
  bbc__spill *s;
  int fd;
  cursor *runs;
  uint32_t *heap; /* run indices, a min-heap on runs[].next.cell */
  uint32_t heap_count;
};

/* Copies n bytes of the run to dst, refilling the buffer by pread. */
static bbc_result cursor_read(bbc__spill_reader *r, cursor *c, void *dst, size_t n) {
  uint8_t *d = dst;
  while (n) {
    if (c->at == c->len) {
      if (c->pos >= c->end) return fail(r->s, "read", EIO); /* a run ends inside a list */
      size_t want = c->end - c->pos < c->size ? (size_t)(c->end - c->pos) : c->size;
      ssize_t got = pread(r->fd, c->buf, want, (off_t)c->pos);
      if (got <= 0) return fail(r->s, "read", got < 0 ? errno : EIO);
      c->pos += (uint64_t)got;
      c->len = (size_t)got;
      c->at = 0;
    }
    size_t k = c->len - c->at < n ? c->len - c->at : n;
    memcpy(d, c->buf + c->at, k);
    c->at += k;
    d += k;
    n -= k;
  }
  return BBC_OK;
}

static bbc_result cursor_advance(bbc__spill_reader *r, cursor *c) {
  if (c->at == c->len && c->pos >= c->end) {
    c->next.cell = UINT64_MAX;
    return BBC_OK;
  }
  return cursor_read(r, c, &c->next, sizeof c->next);
}

static uint64_t key(const bbc__spill_reader *r, uint32_t i) {
  return r->runs[r->heap[i]].next.cell;
}

/* Heap order: by next cell, then by run, so that a cell's lists come in the order of the
 * runs (the precompute's tuple order: their concatenation is then sorted already). */
static int before(const bbc__spill_reader *r, uint32_t i, uint32_t j) {
  uint64_t a = key(r, i), b = key(r, j);
  return a < b || (a == b && r->heap[i] < r->heap[j]);
}

static void sift_down(bbc__spill_reader *r, uint32_t i) {
  for (;;) {
    uint32_t l = 2 * i + 1, m = i;
    if (l < r->heap_count && before(r, l, m)) m = l;
    if (l + 1 < r->heap_count && before(r, l + 1, m)) m = l + 1;
    if (m == i) return;
    uint32_t t = r->heap[i];
    r->heap[i] = r->heap[m];
    r->heap[m] = t;
    i = m;
  }
}

void bbc__spill_reader_free(bbc__spill_reader *r) {
  if (!r) return;
  for (uint32_t i = 0; r->runs && i < r->s->run_count; i++) free(r->runs[i].buf);
  free(r->runs);
  free(r->heap);
  free(r);
}

bbc_result bbc__spill_reader_open(bbc__spill_reader **out, bbc__spill *s) {
  *out = NULL;
  if (s->error[0]) return BBC_ERR_IO;
  if (s->size != s->run_begin) return BBC_ERR_INVALID_ARGUMENT; /* a run is open */
  bbc__spill_reader *r = calloc(1, sizeof *r);
  uint32_t n = s->run_count;
  if (r) {
    r->s = s;
    r->fd = s->file ? fileno(s->file) : -1;
    r->runs = calloc(n ? n : 1, sizeof *r->runs);
    r->heap = malloc(sizeof *r->heap * (n ? n : 1));
  }
  if (!r || !r->runs || !r->heap) {
    bbc__spill_reader_free(r);
    return BBC_ERR_OUT_OF_MEMORY;
  }
  bbc_result res = BBC_OK;
  for (uint32_t i = 0; i < n && res == BBC_OK; i++) {
    cursor *c = &r->runs[i];
    c->pos = s->runs[i].begin;
    c->end = s->runs[i].end;
    c->size = c->end - c->pos < READ_BUFFER ? (size_t)(c->end - c->pos) : READ_BUFFER;
    if (!(c->buf = malloc(c->size))) res = BBC_ERR_OUT_OF_MEMORY;
    if (res == BBC_OK) res = cursor_advance(r, c);
    r->heap[i] = i;
  }
  r->heap_count = n;
  for (uint32_t i = n / 2; i-- > 0;) sift_down(r, i);
  if (res != BBC_OK) {
    bbc__spill_reader_free(r);
    return res;
  }
  *out = r;
  return BBC_OK;
}

uint64_t bbc__spill_reader_next_cell(const bbc__spill_reader *r) {
  return r->heap_count ? key(r, 0) : UINT64_MAX;
}

bbc_result bbc__spill_reader_take(bbc__spill_reader *r, uint64_t cell, bbc__cell_entry **e,
                                  uint32_t *n, uint32_t *cap, int *sources) {
  while (r->heap_count && key(r, 0) <= cell) {
    cursor *c = &r->runs[r->heap[0]];
    if (c->next.cell < cell) return BBC_ERR_INVALID_ARGUMENT; /* asked out of order */
    uint32_t count = c->next.count;
    if (count > UINT32_MAX - *n) return BBC_ERR_OUT_OF_MEMORY;
    if (*n + count > *cap) {
      uint32_t want = *n + count, grown = *cap > UINT32_MAX / 2 ? UINT32_MAX : 2 * *cap;
      if (grown < want) grown = want;
      bbc__cell_entry *m = realloc(*e, sizeof *m * (size_t)grown);
      if (!m) return BBC_ERR_OUT_OF_MEMORY;
      *e = m;
      *cap = grown;
    }
    bbc_result res = cursor_read(r, c, *e + *n, sizeof **e * (size_t)count);
    if (res == BBC_OK) res = cursor_advance(r, c);
    if (res != BBC_OK) return res;
    *n += count;
    ++*sources;
    if (c->next.cell == UINT64_MAX) r->heap[0] = r->heap[--r->heap_count];
    sift_down(r, 0);
  }
  return BBC_OK;
}
