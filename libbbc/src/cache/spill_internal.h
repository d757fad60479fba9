/* The spill store of the cache builder: cell lists that do not fit in the builder's
 * memory budget are written out as sorted runs to a temporary file and read back, all
 * runs merged, when the cache is written. Peak memory then stays bounded by the budget
 * whatever the number of (cell, tuple) entries.
 *
 * The file is created in $TMPDIR (or /tmp) and unlinked at once, so nothing is left
 * behind on any exit, including an interrupt or a crash. */
#ifndef BBC_SPILL_INTERNAL_H
#define BBC_SPILL_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "bbc/common.h"

/* One (tuple id, bound code) entry of a cell's list: 8 bytes. */
typedef struct bbc__cell_entry {
  uint32_t tuple;
  uint32_t code;
} bbc__cell_entry;

typedef struct bbc__spill bbc__spill;

/* An empty store; its file is created with the first run. */
bbc_result bbc__spill_create(bbc__spill **out);
void bbc__spill_free(bbc__spill *s);

/* Appends cell `cell`'s list (n >= 1 entries sorted by strictly increasing tuple) to the
 * run being written; within a run, cells must come in strictly increasing order. A run
 * begins with the first put after bbc__spill_end_run (or creation). BBC_ERR_IO when the
 * file cannot be created or written (a full disk): bbc__spill_error says why, and the
 * store refuses everything afterwards. */
bbc_result bbc__spill_put(bbc__spill *s, uint64_t cell, const bbc__cell_entry *e, uint32_t n);
bbc_result bbc__spill_end_run(bbc__spill *s);

uint32_t bbc__spill_run_count(const bbc__spill *s);
uint64_t bbc__spill_bytes(const bbc__spill *s);

/* One line saying what went wrong with the file, or NULL. */
const char *bbc__spill_error(const bbc__spill *s);

/* Reading back all runs, cell by cell in increasing order. The store must not be
 * written while a reader is open; any number of readers may be opened one after the
 * other (the runs stay). */
typedef struct bbc__spill_reader bbc__spill_reader;
bbc_result bbc__spill_reader_open(bbc__spill_reader **out, bbc__spill *s);
void bbc__spill_reader_free(bbc__spill_reader *r);

/* The smallest cell some run still holds, UINT64_MAX when all are read. */
uint64_t bbc__spill_reader_next_cell(const bbc__spill_reader *r);

/* Appends to (*e, *n, *cap) (realloc'd) every run's list of cell `cell`, which must not
 * be below bbc__spill_reader_next_cell; *sources is incremented per run that had one.
 * The lists are each sorted but not merged with each other. */
bbc_result bbc__spill_reader_take(bbc__spill_reader *r, uint64_t cell, bbc__cell_entry **e,
                                  uint32_t *n, uint32_t *cap, int *sources);

#endif
