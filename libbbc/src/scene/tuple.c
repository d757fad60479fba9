/* Chain type names. */
#include "bbc/tuple.h"

#include <string.h>

static const char *const chain_names[BBC_CHAIN_COUNT] = {"R", "T", "RR", "RT", "TR", "TT"};

const char *bbc_chain_name(bbc_chain chain) {
  return (unsigned)chain < BBC_CHAIN_COUNT ? chain_names[chain] : "?";
}

int bbc_chain_parse(const char *name, bbc_chain *out) {
  for (int i = 0; i < BBC_CHAIN_COUNT; i++) {
    if (strcmp(name, chain_names[i]) == 0) {
      *out = (bbc_chain)i;
      return 1;
    }
  }
  return 0;
}
