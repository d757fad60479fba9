/* The whole public API of libbbc. */
#ifndef BBC_BBC_H
#define BBC_BBC_H

#include "bbc/accel.h"
#include "bbc/bernstein.h"
#include "bbc/bounds.h"
#include "bbc/bsdf.h"
#include "bbc/cache.h"
#include "bbc/common.h"
#include "bbc/grid.h"
#include "bbc/image.h"
#include "bbc/interval.h"
#include "bbc/precompute.h"
#include "bbc/render.h"
#include "bbc/scene.h"
#include "bbc/solver.h"
#include "bbc/specular_path.h"
#include "bbc/texture.h"
#include "bbc/tuple.h"
#include "bbc/validate.h"

#endif
