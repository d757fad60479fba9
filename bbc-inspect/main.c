/* bbc-inspect: a placeholder until its issue lands; it documents itself and refuses work. */
#include <stdio.h>
#include <string.h>

#include "bbc/bbc.h"

static const char help[] =
    "bbc-inspect: not implemented yet in this version of bbc.\n"
    "\n"
    "usage: bbc-inspect [-h|--help] [--version]\n";

int main(int argc, char **argv) {
  if (argc == 2 && (strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "--help") == 0)) {
    fputs(help, stdout);
    return 0;
  }
  if (argc == 2 && strcmp(argv[1], "--version") == 0) {
    printf("bbc-inspect %s\n", bbc_version_string());
    return 0;
  }
  fprintf(stderr, "bbc-inspect: not implemented yet\n%s", help);
  return 2;
}
