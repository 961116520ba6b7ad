/* Room2R2C: a thermal zone as two resistances and two capacities, FMI 2.0 co-simulation.
 *
 * Nodes: zone air (C_air, J/K) and building mass (C_mass, J/K). Conductances (W/K): air-outdoor UA_air
 * (windows, infiltration), air-mass H_am, mass-outdoor UA_mass (opaque envelope). Heat flows into the air:
 * Q_heat - Q_cool (W, both >= 0), 30 % of the solar gain A_sol * (I_dir + I_dif) and half of the occupant
 * gain occ_gain * n_occ; the rest of the solar and occupant gains goes to the mass. Integrated with explicit
 * Euler sub-steps of at most dt_sub seconds; inputs are held constant over a communication step.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"

enum { T_OUT, I_DIR, I_DIF, N_OCC, Q_HEAT, Q_COOL, T_IN, T_MASS, T0, C_AIR, C_MASS, UA_AIR, H_AM, UA_MASS,
       A_SOL, OCC_GAIN, DT_SUB, N_VR };

typedef struct { double r[N_VR]; double time; } Room;

static void defaults(Room *m) {
    memset(m, 0, sizeof(Room));
    m->r[T0] = 21.0; m->r[C_AIR] = 2.0e6; m->r[C_MASS] = 3.0e7; m->r[UA_AIR] = 120.0; m->r[H_AM] = 900.0;
    m->r[UA_MASS] = 60.0; m->r[A_SOL] = 3.0; m->r[OCC_GAIN] = 100.0; m->r[DT_SUB] = 60.0;
    m->r[T_IN] = m->r[T0]; m->r[T_MASS] = m->r[T0];
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) { return fmi2OK; }

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String location,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible, fmi2Boolean logging) {
    if (type != fmi2CoSimulation) return NULL;
    Room *m = (Room *)malloc(sizeof(Room));
    if (m) defaults(m);
    return m;
}
void fmi2FreeInstance(fmi2Component c) { free(c); }
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tol_defined, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stop_defined, fmi2Real stop) {
    ((Room *)c)->time = start; return fmi2OK;
}
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Room *m = (Room *)c; m->r[T_IN] = m->r[T0]; m->r[T_MASS] = m->r[T0]; return fmi2OK;
}
fmi2Status fmi2Terminate(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) { defaults((Room *)c); return fmi2OK; }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Room *m = (Room *)c;
    for (size_t i = 0; i < n; i++) { if (vr[i] >= N_VR) return fmi2Error; value[i] = m->r[vr[i]]; }
    return fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Room *m = (Room *)c;
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= N_VR || vr[i] == T_IN || vr[i] == T_MASS) return fmi2Error;
        m->r[vr[i]] = value[i];
    }
    return fmi2OK;
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) { return n ? fmi2Error : fmi2OK; }

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    if (*state == NULL) *state = malloc(sizeof(Room));
    memcpy(*state, c, sizeof(Room)); return fmi2OK;
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) { memcpy(c, state, sizeof(Room)); return fmi2OK; }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) { free(*state); *state = NULL; return fmi2OK; }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *size) { *size = sizeof(Room); return fmi2OK; }
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t size) {
    memcpy(b, s, sizeof(Room)); return fmi2OK;
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t size, fmi2FMUstate *s) {
    if (*s == NULL) *s = malloc(sizeof(Room));
    memcpy(*s, b, sizeof(Room)); return fmi2OK;
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference z[], size_t nz, const fmi2Real du[], fmi2Real dz[]) {
    return fmi2Error;
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real value[]) { return fmi2Error; }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real value[]) { return fmi2Error; }

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean no_prior) {
    Room *m = (Room *)c;
    double *r = m->r;
    int steps = (int)ceil(h / r[DT_SUB] - 1e-9);
    if (steps < 1) steps = 1;
    double dt = h / steps;
    double solar = r[A_SOL] * (r[I_DIR] + r[I_DIF]), people = r[OCC_GAIN] * r[N_OCC];
    double q_air = r[Q_HEAT] - r[Q_COOL] + 0.3 * solar + 0.5 * people, q_mass = 0.7 * solar + 0.5 * people;
    for (int k = 0; k < steps; k++) {
        double ta = r[T_IN], tm = r[T_MASS];
        double to_air = r[UA_AIR] * (r[T_OUT] - ta) + r[H_AM] * (tm - ta) + q_air;
        double to_mass = r[UA_MASS] * (r[T_OUT] - tm) + r[H_AM] * (ta - tm) + q_mass;
        r[T_IN] = ta + dt * to_air / r[C_AIR];
        r[T_MASS] = tm + dt * to_mass / r[C_MASS];
    }
    m->time = t + h;
    return fmi2OK;
}
fmi2Status fmi2CancelStep(fmi2Component c) { return fmi2Error; }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v) { return fmi2Discard; }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v) {
    if (s == fmi2LastSuccessfulTime) { *v = ((Room *)c)->time; return fmi2OK; }
    return fmi2Discard;
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v) { return fmi2Discard; }
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v) { return fmi2Discard; }
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v) { return fmi2Discard; }
