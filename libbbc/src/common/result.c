/* Descriptions of result codes and the library version. */
#include "bbc/common.h"

const char *bbc_result_string(bbc_result result) {
  /* A switch without default, so the compiler warns when a code is appended to the
   * enum without a description here. */
  switch (result) {
    case BBC_OK:
      return "success";
    case BBC_ERR_INVALID_ARGUMENT:
      return "invalid argument";
    case BBC_ERR_OUT_OF_MEMORY:
      return "out of memory";
    case BBC_ERR_IO:
      return "input/output error";
    case BBC_ERR_UNSUPPORTED:
      return "unsupported feature";
    case BBC_ERR_EMBREE:
      return "Embree error";
    case BBC_ERR_EXR:
      return "OpenEXR error";
    case BBC_ERR_GLTF:
      return "malformed glTF file";
    case BBC_ERR_CANCELLED:
      return "cancelled";
    case BBC_ERR_NOT_BBC:
      return "not a .bbc file";
    case BBC_ERR_VERSION_UNSUPPORTED:
      return "unsupported .bbc format version";
    case BBC_ERR_TRUNCATED:
      return "truncated .bbc file";
    case BBC_ERR_CORRUPT:
      return "corrupt .bbc file";
    case BBC_ERR_CHECKSUM:
      return ".bbc checksum mismatch";
    case BBC_ERR_SCENE_MISMATCH:
      return ".bbc file computed for another scene or parameters";
    case BBC_ERR_SCENE:
      return "unusable scene";
  }
  return "unknown result code";
}

const char *bbc_version_string(void) {
  return BBC_VERSION_STRING;
}
