! SPDX-License-Identifier: BSD-2-Clause
!> The text of `nuno --help` and `nuno --list-keys`. The key lists come
!> from the key table (module input_keys) and the limits from module
!> input_limits, so that the help cannot name a key or a number the input
!> does not have. No MPI, no PETSc.
module input_usage
  use strings, only: pow10_text, kb_text
  use input_keys, only: keys, n_keys, n_groups, key_index, key_type_text, key_group_list
  use input_limits, only: bytes_per_node_bending, bytes_per_node_plain, max_steps, max_outputs
  use input_text, only: item_end
  implicit none
  private
  public :: usage_text, list_keys

contains

  !> Write the `nuno --help` text.
  subroutine usage_text(unit)
    integer, intent(in) :: unit
    write(unit, '(a)') 'usage: mpirun -n P nuno INPUT.nml [PETSc options]', &
      '       nuno --help', &
      '       nuno --version                          the version and the git commit of the build', &
      '       nuno --list-keys                        every namelist key, one a line, tab-separated: name,', &
      '                                               group, type, unit, default, allowed values, meaning', &
      '       nuno INPUT.nml -help                    the PETSc and nuno options of that run''s set-up; runs', &
      '                                               nothing, writes nothing', &
      '', &
      'The options are checked before the first step: one that nothing read (misspelt,', &
      'or not for this solver) is refused naming the nearest known one, and so are an', &
      'integer beyond PETSc''s and a TS type nuno cannot run (input/README.md, "Options', &
      'are honoured or refused"); a few that PETSc reads later (viewers, the solvers of', &
      'the first solve) are reported at the end if nothing read them.', &
      '', &
      'An error is one line on stderr, and every rank exits with status 1; the banner', &
      'that follows is Open MPI''s, for any non-zero exit (mpirun -q hides it).', &
      '', &
      'nuno integrates an implicit mass-spring cloth: an nx x ny lattice of mass points', &
      'joined by Voigt elements (spring + dashpot) to their 8 neighbours, with bending', &
      '(the report''s "paper" model or the energy-based "energy" model), gravity and', &
      'pinned or prescribed nodes, in time with PETSc TS on a DMDA split in strips of', &
      'rows over P ranks. Results go to one HDF5 file with an XDMF file beside it.', &
      'The run writes OUTPUT.partial, locked against a second writer (OUTPUT.lock), and', &
      'renames it onto OUTPUT after its first successful step, or, when an earlier', &
      'OUTPUT exists, once it completes. nuno replaces only its own files, never through', &
      'a symbolic link; OUTPUT may not be an input file (input/README.md, Output files).', &
      ''
    call usage_keys(unit)
    call usage_run_options(unit)
    call usage_petsc_options(unit)
    call usage_newton_options(unit)
  end subroutine usage_text

  !> The --help lines on nuno's own options of a run: input checks, output
  !> files, checkpoints and restart, namelist keys from the command line.
  subroutine usage_run_options(unit)
    integer, intent(in) :: unit
    write(unit, '(a)') '', &
      'Input checks:', &
      '  -nuno_allow_long                             run even with more than '//pow10_text(max_steps)// &
      ' steps (t_end/dt) or', &
      '                                               '//pow10_text(max_outputs)//' output steps (t_end/output_interval)', &
      '', &
      'Output files (input/README.md, "Output files"):', &
      '  -nuno_overwrite                              replace an earlier output file at the first output', &
      '                                               step (default: only once the new run completes)', &
      '', &
      'Checkpoints and restart (input/README.md, "Checkpoints and restart"):', &
      '  -nuno_restart FILE                           continue the run in FILE from its last checkpoint,', &
      '                                               appending to its series (t_end may be later)', &
      '  -nuno_checkpoint_walltime D                  a checkpoint after each D of wall-clock time', &
      '                                               (seconds, 90m, 23h, 1d or H:MM:SS); one is always', &
      '                                               written at the end, on SIGTERM/SIGINT and every', &
      '                                               checkpoint_interval (&output)', &
      '', &
      'Namelist keys from the command line (sweeps without copying files):', &
      '  -nuno_set key=value[,key=value...]           over the file''s values, same checks; a key by its', &
      '                                               name or as group%key; strings quoted, e.g.', &
      '                                               -nuno_set "nx=257,ny=257,output_file=''h257.h5''"', &
      '                                               (recorded in the output''s namelist attribute);', &
      '                                               commas or blanks between keys; several -nuno_set', &
      '                                               are read in order; a key given twice, an empty', &
      '                                               value or one not of the key''s type is refused'
  end subroutine usage_run_options

  !> The --help lines on PETSc's options of the time integration, and which
  !> integrator suits which goal.
  subroutine usage_petsc_options(unit)
    integer, intent(in) :: unit
    write(unit, '(a)') '', &
      'PETSc options (petsc_options in &output; the command line overrides them):', &
      '  -ts_type beuler|theta|cn|bdf|arkimex|rosw   integrator (default: backward Euler, the report''s, with', &
      '                                               the namelist''s fixed dt); also alpha, eimex, glle;', &
      '                                               explicit methods (euler, rk, ...) are refused', &
      '  -ts_adapt_type basic -ts_rtol R -ts_atol A  adaptive steps with error control; without -ts_type they', &
      '                                               use rosw (Rosenbrock-W ra34pw2, the fastest at moderate', &
      '                                               tolerance in docs/workprecision.md)', &
      '  -nuno_adaptive_ts_type T                     that default TS type of adaptive runs (default rosw)', &
      '  -nuno_atol_position A                        absolute tolerance of positions [length] (default', &
      '                                               -ts_atol, else R times the cloth size max(lx, ly))', &
      '  -nuno_atol_velocity B                        absolute tolerance of velocities [length/time] (default', &
      '                                               the position one per time unit); velocities also get R |v|', &
      '  -ts_monitor, -snes_monitor, -ksp_monitor     progress of steps, Newton, Krylov', &
      '  -snes_rtol R, -snes_max_it N                 Newton tolerance and iterations', &
      '  -snes_type ksponly                           Baraff-Witkin mode: one linearised solve a step', &
      '  -log_view                                    timings at the end (in petsc_options too, but', &
      '                                               -log_view :FILE, like every viewer that writes a', &
      '                                               file, only on the command line)', &
      '', &
      'Which integrator for which goal (docs/workprecision.md, docs/convergence.md):', &
      '  fast, moderate accuracy                      -ts_adapt_type basic [-ts_rtol R]: rosw ra34pw2, final', &
      '    (errors 1e-3 .. 1e-5 of the cloth size)    error 0.3-12 R measured (default 2-norm)', &
      '  tight accuracy, a final position error E     -ts_type arkimex -ts_arkimex_type 5', &
      '    (relative to the cloth size)               -ts_arkimex_fully_implicit -ts_adapt_type basic', &
      '                                               -ts_adapt_wnormtype infinity -ts_rtol E  (at most 10 E', &
      '                                               measured; -ts_type bdf -ts_bdf_order 4 or 5 is often', &
      '                                               faster, but its error is not tied to R: check it)', &
      '  speed on large lattices                      -snes_type ksponly -reduced_ksp_rtol 1e-3 with fixed', &
      '                                               steps: the Baraff-Witkin mode, one linear solve a step,', &
      '                                               first order', &
      '  reproducible runs                            fixed steps (no -ts_adapt_type) with -ts_dt DT: the same', &
      '                                               steps whatever the solution, unless a Newton solve fails:', &
      '                                               its step is retried at dt/4 (with contact an impact can', &
      '                                               do it), which the closing line and /run retried_steps', &
      '                                               count; beuler (default) is order 1, -ts_type cn order 2,', &
      '                                               -ts_type rosw order 3 at about the cost of cn', &
      '                                               (fixed-step bdf 3-5: order 2, see docs)'
  end subroutine usage_petsc_options

  !> The --help lines on the Newton step and its linear solves.
  subroutine usage_newton_options(unit)
    integer, intent(in) :: unit
    write(unit, '(a)') '', &
      'The Newton step (docs/design.md):', &
      '  -nuno_jacobian reduced|full                  reduced (default): only the 3-dof velocity system', &
      '                                               S = a M - C - K/a is assembled and the 6-dof step is', &
      '                                               solved exactly around it; full: the 6-dof Jacobian', &
      '  -reduced_ksp_type, -reduced_pc_type, ...     the inner solver of S (default FGMRES, rtol 1e-6, with', &
      '                                               nuno''s structured multigrid where 3 levels fit, else', &
      '                                               block Jacobi/ILU; CG when S is symmetric and another', &
      '                                               preconditioner is given); -reduced_ksp_view', &
      '  -nuno_mg stencil|petsc                       the inner multigrid: nuno''s (default; single precision,', &
      '                                               stored by stencil offset, no PETSc matrix) or PETSc''s', &
      '                                               PCMG with Galerkin operators and SOR', &
      '  -nuno_mg_cycle kaskade|v                     nuno''s multigrid: kaskade (default: restrict the', &
      '                                               right-hand side, then only upwards) or V-cycles', &
      '  -nuno_mg_sweeps N, -nuno_mg_levels N         symmetric Gauss-Seidel sweeps a smoothing (1), levels', &
      '                                               (0: as many as fit, down to 5 nodes a side)', &
      '  -reduced_dm_mat_type aij|baij|sbaij          storage of S with -reduced_pc_type (default: aij for', &
      '                                               multigrid, baij else); nuno''s multigrid needs none', &
      '  -nuno_pc_lag N                               rebuild the inner preconditioner every N assemblies', &
      '                                               (default 3 with the multigrid, 20 with its cubic', &
      '                                               interpolation, 1 otherwise; and after a keyframe or', &
      '                                               release; a failed solve rebuilds it and retries)', &
      '  -nuno_pc_rebuild_growth R                    and when a solve''s cycles per decade pass R times', &
      '                                               those of the first solve after a rebuild (1.5; 0: off)', &
      '  -nuno_mg_interpolation auto|linear|cubic|coarse_cubic  interpolation of the inner multigrid', &
      '                                               (auto: with bending, whose fourth-order modes', &
      '                                               bilinear transfer does not carry, cubic on every', &
      '                                               level but the finest, whose coarse correction is', &
      '                                               interpolated cubic too; linear without)', &
      '  -nuno_newton_forcing [true|false]            Newton solves each inner system only as far as the', &
      '                                               step needs: its Newton remainder, or half the residual', &
      '                                               at which Newton stops (default true; false with', &
      '                                               obstacles, see &contact)', &
      '  -nuno_inner_guess auto|none|previous|extrapolate|project  the inner solve''s initial guess:', &
      '                                               the least-squares combination of the last 8 inner', &
      '                                               solves (project; auto: with bending), at a step''s', &
      '                                               first Newton iteration the last two steps'' first', &
      '                                               corrections extrapolated, the last one, or zero', &
      '                                               (auto: without bending)', &
      '  -nuno_newton_start auto|linear|cubic|consistent  beuler: Newton starts a step from the last two', &
      '                                               states extrapolated (linear, PETSc''s) or from the', &
      '                                               polynomial through the last four (cubic; auto: for', &
      '                                               Newton at fixed steps, linear with -snes_type ksponly);', &
      '                                               consistent: cubic with positions x_n + dt v', &
      '  -snes_lag_jacobian N                         S assembled every N Newton iterations (default 2: the', &
      '                                               second iteration of a step reuses the first one''s S)', &
      '  -ts_theta_initial_guess_extrapolate          beuler starts Newton from x + dt xdot (default true,', &
      '                                               reduced path)', &
      '  -nuno_snes_floor F                           a residual below F times its start or the round-off', &
      '                                               floor that stops decreasing is converged, on both paths', &
      '                                               (default 1e-6; 0: off)', &
      '  -snes_ksp_ew                                 Eisenstat-Walker: its forcing term is the inner rtol', &
      '  -nuno_gauss_newton                           energy bending: Gauss-Newton blocks -k_b J^T J in the', &
      '                                               assembled matrix, S or the 6-dof Jacobian (an inexact', &
      '                                               Newton; with full and -snes_mf_operator: exact operator', &
      '                                               applied matrix-free, Gauss-Newton preconditioner)', &
      '  -nuno_clamp_compression                      drop the indefinite compression term of the springs', &
      '                                               from the assembled matrix (preconditioner use)', &
      '  -nuno_linesearch_fallback bt|l2|none         after a failed Newton solve, the rest of the run takes', &
      '                                               this line search instead of full steps (default bt)', &
      'PETSc''s linear-solver options on the default (reduced) path act on the inner solve of S:', &
      '  -ksp_*, -pc_*, -sub_*, -mg_levels_*, -mg_coarse_*  read as -reduced_ksp_*, -reduced_pc_*, ...:', &
      '                                               -pc_type lu is -reduced_pc_type lu (an exact inner solve),', &
      '                                               -ksp_type preonly -pc_type lu a direct one; -pc_type', &
      '                                               fieldsplit, shell and -dm_mat_type are refused there', &
      'With -nuno_jacobian full (PETSc''s options act on the 6-dof solve as usual):', &
      '  -ksp_type gmres|bcgs|preonly, -pc_type ilu|lu|bjacobi|fieldsplit|gamg', &
      '  -dm_mat_type baij|aij                        Jacobian storage (default baij 6x6; aij for fieldsplit)'
  end subroutine usage_newton_options

  !> The --help lines on the input file: the groups and their keys, from
  !> the key table (module input_keys).
  subroutine usage_keys(unit)
    integer, intent(in) :: unit
    character(8), parameter :: order(n_groups) = &
      [character(8) :: 'scene', 'lattice', 'material', 'time', 'output', 'identify', 'control', 'contact']
    character(:), allocatable :: line, list, word
    integer :: g, p, q
    write(unit, '(a)') 'INPUT.nml holds Fortran namelist groups, each optional, each at most once, and', &
      'nothing else but blanks and ! comments (an empty file or stray text is an error):'
    do g = 1, n_groups
      list = key_group_list(order(g))
      line = '  &'//order(g)//'  '
      p = 1
      do while (p <= len(list))
        ! A key with the ', ' after it.
        q = item_end(list, p, ', ')
        word = list(p:min(q + 1, len(list)))
        if (len(line) + len(trim(word)) > 90) then
          write(unit, '(a)') trim(line)
          line = repeat(' ', 13)
        end if
        line = line//word
        p = q + 2
      end do
      write(unit, '(a)') line
      select case (trim(order(g)))
      case ('scene')
        write(unit, '(a)') '             scene is one of '//trim(keys(key_index('scene'))%allowed)
      case ('identify')
        write(unit, '(a)') '             fit parameters to an observed motion (docs/identification.md);', &
          '             -identify_check_gradient prints the adjoint gradient against central', &
          '             differences and stops'
      case ('control')
        write(unit, '(a)') '             optimise the keyframes of the driven nodes so that the cloth reaches', &
          '             the target (docs/identification.md); -control_check_gradient as above'
      case ('contact')
        write(unit, '(a)') '             rigid obstacles (plane, sphere, box, capsule), static or moving on', &
          '             keyframes: barrier contact, friction (docs/design.md, "Contact");', &
          '             n_obstacles = 0 (default): none'
      end select
    end do
    write(unit, '(a)') 'The scene sets the defaults of every other key. Every key, its unit and its', &
      'default: nuno --list-keys, input/README.md; ready-made inputs: input/*.nml. Real', &
      'keys must be finite (no NaN, Inf), the mass and the material constants at most', &
      '1e30 (the mass at least 1e-30); a lattice beyond the index range or the memory', &
      'of the ranks'' hosts (at least '//kb_text(bytes_per_node_bending)//' KB a node with bending, '// &
      kb_text(bytes_per_node_plain)//' KB without) is refused.'
  end subroutine usage_keys

  !> `nuno --list-keys`: one line per key, tab-separated: name, group, type,
  !> unit, default, allowed values, meaning; a first line of column names
  !> that starts with '#'.
  subroutine list_keys(unit)
    integer, intent(in) :: unit
    character(1), parameter :: tab = achar(9)
    integer :: k
    write(unit, '(a)') '# name'//tab//'group'//tab//'type'//tab//'unit'//tab//'default'//tab//'allowed'//tab//'meaning'
    do k = 1, n_keys
      write(unit, '(a)') trim(keys(k)%name)//tab//trim(keys(k)%group)//tab//key_type_text(k)//tab// &
        trim(keys(k)%unit)//tab//trim(keys(k)%default)//tab//trim(keys(k)%allowed)//tab//trim(keys(k)%meaning)
    end do
  end subroutine list_keys

end module input_usage
