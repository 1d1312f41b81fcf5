/* The footpad's Maxwell arms as MuJoCo activation dynamics (mjcb_act_dyn).

   An arm is a passive DC motor whose electrical equation is the arm's (models/footpad.py,
   `maxwell_arm`): L i' = -R i - K v, with dynprm[0] = L / R (the arm's time constant tau) and
   gainprm = [R, K]. MuJoCo's own dcmotor dynamics couple it implicitly in the discrete
   integrator; here it is stepped explicitly like any activation. Actuators carry
   dynprm[9] = MAXWELL_ARM_MARK; any other user-dynamics actuator gets 0. */
#include <mujoco/mujoco.h>

#define MAXWELL_ARM_MARK 6174.0

mjtNum maxwell_arm_act_dyn(const mjModel* m, const mjData* d, int id) {
  const mjtNum* dyn = m->actuator_dynprm + id * mjNDYN;
  const mjtNum* gain = m->actuator_gainprm + id * mjNGAIN;
  if (dyn[9] != MAXWELL_ARM_MARK) {
    return 0;
  }
  mjtNum tau = dyn[0], resistance = gain[0], motorconst = gain[1];
  return -(d->act[m->actuator_actadr[id]]
           + motorconst / resistance * d->actuator_velocity[id]) / tau;
}
