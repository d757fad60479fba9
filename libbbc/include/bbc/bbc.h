/* The whole public API of libbbc. */
#ifndef BBC_BBC_H
#define BBC_BBC_H

#include "bbc/accel.h"
#include "bbc/common.h"
#include "bbc/image.h"
#include "bbc/render.h"
#include "bbc/scene.h"
#include "bbc/tuple.h"

#endif
