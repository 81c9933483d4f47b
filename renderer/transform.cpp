#include "renderer/transform.h"
