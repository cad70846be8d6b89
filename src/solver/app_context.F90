! SPDX-License-Identifier: BSD-2-Clause
!> The solver's context, passed to every PETSc callback as the user
!> context, and the C functions of the time loop (src/solver/nuno_signals.c).
!> The context holds the shared objects (DMDA, TS, state, lattice,
!> constraints, the reduced solver) and one record per concern; each
!> record's type has private components and lives in the module that
!> writes it (model_state, newton_state, newton_start, step_settings,
!> energy_integrals, run_progress, run_error; process_models, reduced), so
!> that the compiler keeps every write in its owner (docs/design.md,
!> "Records and their owners"). The configuration is the caller's, read
!> only (tests/python/test_record_owners.py checks that nothing writes
!> through the pointer).
module app_context
#include "petsc/finclude/petscts.h"
  use petscts
  use petscdmda
  use mpi
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_intptr_t
  use kinds, only: rp
  use config, only: nuno_config
  use lattice, only: lattice_t
  use process_models, only: pm_list_t
  use forces, only: jac_buffer_t
  use constraints, only: constraint_set_t
  use newton_start, only: newton_start_t
  use newton_state, only: newton_state_t
  use model_state, only: model_state_t, assembly_t
  use reduced, only: reduced_t
  use step_settings, only: step_settings_t
  use energy_integrals, only: energy_integrals_t
  use run_progress, only: progress_t
  use run_error, only: run_error_t
  implicit none
  private
  public :: app_ctx
  public :: nuno_walltime_arm, nuno_checkpoint_due, nuno_signal_agreed, nuno_signals_install, nuno_ts_stop
  public :: nuno_output_arm, nuno_ts_interpolates

  interface
    !> src/solver/nuno_signals.c: SIGTERM/SIGINT end the run after the current step.
    integer(c_int) function nuno_signals_install(ts) bind(C, name='nuno_signals_install')
      import :: c_int, c_intptr_t
      integer(c_intptr_t) :: ts             !< the TS handle (tTS%v), passed as TS*
    end function nuno_signals_install
    integer(c_int) function nuno_signal_agreed() bind(C, name='nuno_signal_agreed')
      import :: c_int
    end function nuno_signal_agreed
    !> src/solver/nuno_signals.c: -nuno_checkpoint_walltime, agreed after each step.
    !> Due after a step: TSSolve ends there (nuno_checkpoint_due() = 2) and
    !> the run driver writes the checkpoint (advance_window).
    subroutine nuno_walltime_arm(seconds) bind(C, name='nuno_walltime_arm')
      import :: c_double
      real(c_double), value :: seconds
    end subroutine nuno_walltime_arm
    integer(c_int) function nuno_checkpoint_due() bind(C, name='nuno_checkpoint_due')
      import :: c_int
    end function nuno_checkpoint_due
    !> src/solver/nuno_signals.c: end TSSolve after the step that reaches t
    !> (an output time inside the window, less its tolerance); armed = 0: none.
    subroutine nuno_output_arm(armed, t) bind(C, name='nuno_output_arm')
      import :: c_int, c_double
      integer(c_int), value :: armed
      real(c_double), value :: t
    end subroutine nuno_output_arm
    !> yes = 1 where TSInterpolate of the TS's method gives its solution
    !> between the last two steps (measured on PETSc 3.18.5), else 0.
    integer(c_int) function nuno_ts_interpolates(ts, yes) bind(C, name='nuno_ts_interpolates')
      import :: c_int, c_intptr_t
      integer(c_intptr_t) :: ts             !< the TS handle (tTS%v), passed as TS*
      integer(c_int) :: yes
    end function nuno_ts_interpolates
    !> Stop TSSolve after this step (TS_CONVERGED_USER).
    integer(c_int) function nuno_ts_stop(ts) bind(C, name='nuno_ts_stop')
      import :: c_int, c_intptr_t
      integer(c_intptr_t) :: ts             !< the TS handle (tTS%v), passed as TS*
    end function nuno_ts_stop
  end interface


  !> Everything the callbacks need; passed to PETSc as the user context.
  type :: app_ctx
    !> the run's configuration, read only: the caller's (main program's),
    !> which solver_create points to (identification points it to its own
    !> trial configuration); the effective dt and t_end are step's
    type(nuno_config), pointer :: cfg => null()
    type(lattice_t) :: lat
    type(constraint_set_t) :: cs
    type(tDM) :: da
    type(tTS) :: ts
    type(tVec) :: u                             !< global state
    logical :: use_reduced = .true.             !< the reduced 3-dof solve (module reduced), the default
    type(reduced_t) :: red                      !< its matrices and inner solver
    integer :: comm = MPI_COMM_NULL, rank = 0, size = 1
    real(rp), allocatable :: xout(:, :, :)      !< (3, 0:nx-1, ys:ye) output buffer
    real(rp), allocatable :: vout(:, :, :)      !< (3, 0:nx-1, ys:ye) output buffer
    type(run_error_t) :: error                  !< the (collective) error that ended the run (module run_error)
    type(model_state_t) :: model                !< work arrays, the window's constrained nodes (module model_state)
    type(assembly_t) :: asm                     !< the 6-dof Jacobian, -nuno_jacobian full (module model_state)
    type(newton_state_t) :: newton              !< Newton's policy state (module newton_state)
    type(newton_start_t) :: start               !< beuler's Newton start and its kept states (module newton_start)
    type(step_settings_t) :: step               !< the time integration as used (module step_settings)
    type(energy_integrals_t) :: energy          !< dissipated energy, constraint work (module energy_integrals)
    type(progress_t) :: progress                !< wall clock, output steps, stall check (module run_progress)
    !> the process models (contact with obstacles; module process_models:
    !> their hooks' loops, and the node blocks every assembly adds); empty
    !> in a scene without obstacles
    type(pm_list_t) :: pms
  end type app_ctx

end module app_context
