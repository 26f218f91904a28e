// The kernels' BDPT settings from the integrator settings: one translation shared by BDPT,
// CBDPT and MLT (which reuse BDPT's connections and weights).
#pragma once

#include "integrators/integrator.h"

#include "cb_bdpt.h"

namespace cb {

inline cbk::BdptSettings bdptSettingsFor(const IntegratorSettings& settings) {
    cbk::BdptSettings bdpt{};
    bdpt.eyeVertices = settings.eyeVertices;
    bdpt.lightVertices = settings.lightVertices;
    bdpt.weights = settings.weights == "lafortune" ? CB_WEIGHTS_LAFORTUNE : CB_WEIGHTS_POWER;
    bdpt.debugS = settings.debugS; // -1 unless BDPT's --strategy debug mode
    bdpt.debugT = settings.debugT;
    bdpt.maxPathVertices = settings.maxPathVertices; // caps already resolved by makeIntegrator
    return bdpt;
}

} // namespace cb
