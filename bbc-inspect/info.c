/* bbc-inspect info: the header, sections, parameters, fingerprint and counts of a cache. */
#include <stdio.h>

#include "bbc/tuple.h"
#include "inspect.h"

int cmd_info(const char *path) {
  bbc_cache *c = inspect_open_cache(path);
  bbc_cache_info in;
  bbc_cache_get_info(c, &in);
  printf("file         %s\n", path);
  printf("format       %u.%u (this reader: %d.%d)\n", in.version_major, in.version_minor,
         BBC_FORMAT_VERSION_MAJOR, BBC_FORMAT_VERSION_MINOR);
  printf("file size    %llu bytes\n", (unsigned long long)in.file_size);
  printf("writer       %s\n", in.writer[0] ? in.writer : "(no INFO section)");
  printf("sections     %u\n", in.section_count);
  for (uint32_t i = 0; i < in.section_count; i++) {
    bbc_cache_section s;
    bbc_cache_get_section(c, i, &s);
    printf("  %-4s  %-8s  offset %10llu  size %12llu  crc32 0x%08x\n", s.name,
           (s.flags & 1) ? "required" : "optional", (unsigned long long)s.offset,
           (unsigned long long)s.size, s.checksum);
  }
  char chains[64];
  const bbc_precompute_params *p = &in.params;
  printf(
      "parameters   chains %s, max_level %u, sigma %g, alpha %g (one bounce) %g (two), "
      "m %g, grid %u, remainder %s\n",
      inspect_chains_text(p->chains, chains, sizeof chains), p->max_level, p->sigma,
      p->alpha_single, p->alpha_double, p->m, p->grid_resolution, p->remainder ? "on" : "off");
  if (p->max_level_double)
    printf("two bounces  max_level %u (point, spot and sun lights)\n", p->max_level_double);
  if (p->area_lights)
    printf("area lights  on, double scattering %s, alpha %g%s\n", p->area_double ? "on" : "off",
           p->alpha_area > 0 ? p->alpha_area : p->alpha_double,
           p->alpha_area > 0 ? "" : " (the two-bounce alpha: a cache before 1.5)");
  if (p->beam_receivers)
    printf("receivers    beam: receiver triangles not on a plane share one tuple per prefix\n");
  if (p->cell_levels)
    printf("cell levels  %u: each grid and coarser ones of up to %u x %u of its cells\n",
           p->cell_levels, 1u << (p->cell_levels - 1), 1u << (p->cell_levels - 1));
  const bbc_fingerprint *f = &in.fingerprint;
  printf(
      "fingerprint  %016llx (geometry %016llx, materials %016llx, meshes %016llx, "
      "lights %016llx, parameters %016llx)\n",
      (unsigned long long)f->total, (unsigned long long)f->geometry,
      (unsigned long long)f->materials, (unsigned long long)f->meshes,
      (unsigned long long)f->lights, (unsigned long long)f->params);
  printf("scene        %u vertices, %u triangles, %u meshes, %u materials, %u lights\n",
         in.scene_vertex_count, in.scene_triangle_count, in.scene_mesh_count,
         in.scene_material_count, in.scene_light_count);
  uint64_t per_chain[BBC_CHAIN_COUNT] = {0};
  const bbc_tuple *t = bbc_cache_tuples(c);
  for (uint32_t i = 0; i < in.tuple_count; i++) per_chain[t[i].chain]++;
  bbc_cache_shard shard;
  if (bbc_cache_get_shard(c, &shard))
    printf(
        "shard        %u/%u of a sharded precompute: %u of its %llu candidate tuples stored "
        "(candidates hash %016llx); incomplete alone, merge all %u with bbc-inspect merge\n",
        shard.index, shard.count, in.tuple_count, (unsigned long long)shard.candidate_count,
        (unsigned long long)shard.candidates_hash, shard.count);
  printf("tuples       %u", in.tuple_count);
  int listed = 0;
  for (int k = 0; k < BBC_CHAIN_COUNT; k++)
    if (per_chain[k])
      printf("%s%s %llu", listed++ ? ", " : " (", bbc_chain_name((bbc_chain)k),
             (unsigned long long)per_chain[k]);
  printf("%s\n", listed ? ")" : "");
  cli_print_tuples_per_light(stdout, "  ", t, in.tuple_count,
                             in.scene_light_count + in.scene_emitter_count, NULL);
  const bbc_grid *g = bbc_cache_grid(c);
  printf("receivers    %u\n", in.receiver_count);
  for (uint32_t i = 0; i < g->receiver_count; i++) {
    const bbc_receiver *r = &g->receivers[i];
    printf("  %u: mesh %u, %s, %u x %u cells, triangles %u..%u, domain [%g, %g] x [%g, %g]\n", i,
           r->mesh, bbc_parameterisation_name(r->parameterisation), r->width, r->height,
           r->first_triangle, r->first_triangle + r->triangle_count - 1, r->domain[0], r->domain[2],
           r->domain[1], r->domain[3]);
  }
  printf("cells        %llu, %llu with a list\n", (unsigned long long)in.cell_count,
         (unsigned long long)in.nonempty_cell_count);
  printf("entries      %llu (%.1f per non-empty cell)\n", (unsigned long long)in.entry_count,
         in.nonempty_cell_count ? (double)in.entry_count / (double)in.nonempty_cell_count : 0.0);
  printf("chunks       %u\n", in.chunk_count);
  printf("cell lists   %llu bytes decoded, %llu compressed, ratio %.2f\n",
         (unsigned long long)in.decoded_bytes, (unsigned long long)in.compressed_bytes,
         in.compressed_bytes ? (double)in.decoded_bytes / (double)in.compressed_bytes : 0.0);
  bbc_cache_close(c);
  return 0;
}
