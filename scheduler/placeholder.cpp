#include "sampling/vecmath.h"
