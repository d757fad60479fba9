/* Shared definitions of the bbc public API: export macro, result codes, the error
 * callback, versions and small value types. */
#ifndef BBC_COMMON_H
#define BBC_COMMON_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(BBC_BUILDING_LIBRARY)
#define BBC_API __attribute__((visibility("default")))
#else
#define BBC_API
#endif

/* Result codes. Values are appended, never renumbered: they are part of the ABI and
 * appear in test corpus file names. */
typedef enum bbc_result {
  BBC_OK = 0,
  BBC_ERR_INVALID_ARGUMENT = 1, /* a parameter is out of its documented range */
  BBC_ERR_OUT_OF_MEMORY = 2,
  BBC_ERR_IO = 3,                   /* a file could not be opened, read or written */
  BBC_ERR_UNSUPPORTED = 4,          /* valid input using a feature bbc does not support */
  BBC_ERR_EMBREE = 5,               /* Embree reported an error */
  BBC_ERR_EXR = 6,                  /* OpenEXR reported an error */
  BBC_ERR_GLTF = 7,                 /* the glTF file is malformed (syntax, references) */
  BBC_ERR_CANCELLED = 8,            /* a progress callback asked to stop */
  BBC_ERR_NOT_BBC = 9,              /* not a .bbc file at all (magic) */
  BBC_ERR_VERSION_UNSUPPORTED = 10, /* a .bbc file of a newer major version */
  BBC_ERR_TRUNCATED = 11,           /* a .bbc file shorter than its structures say */
  BBC_ERR_CORRUPT = 12,             /* a .bbc file whose structures are inconsistent */
  BBC_ERR_CHECKSUM = 13,            /* a .bbc section whose checksum does not match */
  BBC_ERR_SCENE_MISMATCH = 14,      /* a .bbc file computed for another scene/parameters */
  BBC_ERR_SCENE = 15                /* a well-formed glTF whose content bbc cannot use
                                       (no light, no camera, NaN positions, ...) */
} bbc_result;

/* A static, never-NULL description of a result code. */
BBC_API const char *bbc_result_string(bbc_result result);

/* Called on the failing thread with the code and a one-line, human-readable message
 * (file, offset, section, third-party text). The message is only valid during the
 * call. Warnings use the same signature with code BBC_OK. */
typedef void (*bbc_message_fn)(void *user, bbc_result code, const char *message);

/* Versions: the library, and the .bbc format it reads and writes. */
#define BBC_FORMAT_VERSION_MAJOR 1
#define BBC_FORMAT_VERSION_MINOR 9
BBC_API const char *bbc_version_string(void);

typedef struct bbc_vec3 {
  double x, y, z;
} bbc_vec3;

/* A progress callback for long operations: done of total units finished. A non-zero
 * return cancels the operation, which then returns BBC_ERR_CANCELLED. It may be called
 * from any thread, but never from two threads at once. */
typedef int (*bbc_progress_fn)(void *user, uint64_t done, uint64_t total);

#ifdef __cplusplus
}
#endif

#endif
