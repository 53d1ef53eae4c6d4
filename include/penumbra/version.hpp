#pragma once
#define PENUMBRA_VERSION "0.1.0"
