/* bbc-precompute: a placeholder until its issue lands; it documents itself and refuses work. */
#include <stdio.h>
#include <string.h>

#include "bbc/bbc.h"

static const char help[] =
    "bbc-precompute: not implemented yet in this version of bbc.\n"
    "\n"
    "usage: bbc-precompute [-h|--help] [--version]\n";

int main(int argc, char **argv) {
  if (argc == 2 && (strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "--help") == 0)) {
    fputs(help, stdout);
    return 0;
  }
  if (argc == 2 && strcmp(argv[1], "--version") == 0) {
    printf("bbc-precompute %s\n", bbc_version_string());
    return 0;
  }
  fprintf(stderr, "bbc-precompute: not implemented yet\n%s", help);
  return 2;
}
