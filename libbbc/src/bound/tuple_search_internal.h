/* The candidate tuples as a stream (tuples.c): the search of bbc_tuples_find, handed out
 * a block at a time in its deterministic order, so that no one has to hold the whole
 * list. A block is the tuples of a window of consecutive (light, T1) prefixes searched
 * in parallel, each chunk of prefixes given its share of the block budget; a chunk
 * whose tuples do not fit stops where its share is full, inside a prefix if need be
 * (at a second triangle and a receiver), and carries on from there once its block has
 * been handed out. The window narrows when its chunks do not fit and widens when its
 * tuples are far below the budget. So the memory a search holds never exceeds the
 * budget, however the candidates crowd on a few casters, and the order of the tuples
 * is the same for any budget and any number of threads. */
#ifndef BBC_TUPLE_SEARCH_INTERNAL_H
#define BBC_TUPLE_SEARCH_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "bbc/scene.h"
#include "bbc/tuple.h"

typedef struct bbc__tuple_search bbc__tuple_search;

/* A search of the candidates of the scene's point lights for the chain types of
 * `chains`, followed by those of its emitters (light point_light_count + e) for
 * `area_chains` (0: none), in the order of bbc_tuples_find then bbc_tuples_find_area;
 * with `beam`, receiver triangles not on a plane give beam tuples (bbc_tuples_find_beam).
 * `threads` searching threads (0: every core); block_bytes is the most bytes of tuples
 * the search holds at once (0: 16 MiB; at least one tuple per thread).
 * *out is NULL on failure; free with bbc__tuple_search_free. Not thread-safe: one
 * caller at a time, which the search's own threads serve. */
bbc_result bbc__tuple_search_create(bbc__tuple_search **out, const bbc_scene *scene,
                                    uint32_t chains, uint32_t area_chains, int beam, int threads,
                                    size_t block_bytes);

/* The next candidates in order: *tuples (borrowed, valid until the next call or the
 * free) and *count, never 0 before the end; *count == 0 at the end. After a failure the
 * search is over (every later call returns the same code). */
bbc_result bbc__tuple_search_next(bbc__tuple_search *s, const bbc_tuple **tuples, size_t *count);

/* How far the search is: prefixes (light, T1) searched of the total. */
void bbc__tuple_search_progress(const bbc__tuple_search *s, uint64_t *done, uint64_t *total);

/* The most bytes of tuples the search held at once (at most the block budget). */
size_t bbc__tuple_search_peak_bytes(const bbc__tuple_search *s);

void bbc__tuple_search_free(bbc__tuple_search *s); /* NULL is allowed */

/* Narrows lo..hi to where the light of tuple t can land after its last specular vertex:
 * when the search's medium rule finds it inside a closed mesh (bbc__media_enclosure), it
 * lands inside that mesh, so inside the mesh's bounding box (every segment to a point
 * outside would cross the mesh, a specular vertex more than the chain has). Returns 0
 * when nothing of lo..hi is left. Exact on the float data. */
int bbc__tuple_landing_box(const bbc_scene *scene, const bbc_tuple *t, double lo[3], double hi[3]);

/* A control for the tests, never set otherwise (1): 0 keeps the flat receivers that lie
 * in a face of an enclosing mesh's box where no triangle of the mesh lies (tuples.c,
 * medium_reaches), tuples with no path that lands on an area. */
extern int bbc__tuple_face_rule;

#endif
