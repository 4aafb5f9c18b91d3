// No-reference and blind-assessment metrics: Hautière's visible-edge indicators (e, r̄, σ), UIQM
// and UCIQE. One include for the metric registry and the CLI.
#pragma once

#include "metrics/uciqe.h"
#include "metrics/uiqm.h"
#include "metrics/visible_edges.h"
