/// \file
/// Umbrella header: everything a user of penumbra needs.
#pragma once
#include "penumbra/ambient.hpp"
#include "penumbra/context.hpp"
#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "penumbra/extraction.hpp"
#include "penumbra/flip.hpp"
#include "penumbra/heatmap.hpp"
#include "penumbra/image.hpp"
#include "penumbra/lights.hpp"
#include "penumbra/reference.hpp"
#include "penumbra/renderer.hpp"
#include "penumbra/scan.hpp"
#include "penumbra/scene.hpp"
#include "penumbra/suggest.hpp"
#include "penumbra/version.hpp"
