! SPDX-License-Identifier: BSD-2-Clause
!> The inner preconditioner's choice and nuno's multigrid glue for the
!> reduced solve (module reduced): PETSc's defaults when it is not nuno's
!> multigrid (default_preconditioner, the DMDA interpolations for PCMG),
!> and with nuno's multigrid (module stencil_mg) S stored by stencil offset,
!> its product a MATSHELL (stencil_mult), one cycle a PCSHELL (mg_pc_apply),
!> the coarse levels (mg_coarse_levels) and the fused product of a cycle's
!> output with S; the multigrid's options (-nuno_mg ..., mg_options_read).
!> Its record (mg_glue_t, the MATSHELL's and the PCSHELL's context) has
!> private components: only this module writes it.
module reduced_mg
#include "petsc/finclude/petscksp.h"
#include "petsc/finclude/petscdmda.h"
  use petscksp
  use petscdmda
  use mpi
  use, intrinsic :: iso_c_binding, only: c_int, c_intptr_t, c_int64_t, c_char, c_ptr, c_f_pointer
  use kinds, only: rp
  use strings, only: itoa
  use solver_choices, only: INTERP_LINEAR, INTERP_CUBIC, INTERP_COARSE_CUBIC, MG_NAMES, MG_STENCIL, CYCLE_NAMES, &
                            CYCLE_KASKADE, PRODUCT_NAMES, PRODUCT_DOUBLE, PRODUCT_FUSED, COARSE_NAMES, COARSE_AUTO, COARSE_REDISCRETIZE, &
                            GATHER_NAMES, GATHER_AUTO
  use shell_context, only: PCShellSetContext, PCShellGetContext, MatShellSetContext, MatShellGetContext
  use lattice, only: lattice_t
  use reduced_assembly, only: assemble_stencil
  use node_blocks, only: node_blocks_t
  use process_models, only: pm_list_t, pm_list_pairs_on
  use reduced_pairs, only: pair_product_add
  use offset_product, only: stencil_product, offset_count
  use interpolation, only: cubic_weights
  use mg_kernels, only: stencil_t
  use stencil_mg, only: stencil_mg_t, mg_create, mg_destroy, mg_build_coarse, mg_apply, mg_describe, mg_product, &
                        mg_fine_level
  use mg_coarse, only: mg_coarse_t, mg_coarse_init, mg_coarse_build, mg_coarse_free
  implicit none
  private
  public :: mg_glue_t, mg_glue_matrix, mg_glue_set_pairs, mg_glue_pc, mg_glue_free, mg_glue_assemble, mg_glue_built, mg_glue_describe
  public :: mg_coarse_levels, levels_that_fit, default_preconditioner, mg_interpolations, true_residual_defaults
  public :: mg_options_t, mg_options_read
  public :: INTERP_LINEAR, INTERP_CUBIC, INTERP_COARSE_CUBIC

  !> The options of nuno's multigrid as read (-nuno_mg, -nuno_mg_cycle,
  !> -nuno_mg_sweeps, -nuno_mg_levels, -nuno_mg_product, -nuno_mg_coarse):
  !> a value record, the choices as module solver_choices' codes.
  type :: mg_options_t
    integer :: impl = MG_STENCIL           !< MG_STENCIL (nuno's) or PETSc's PCMG
    integer :: cycle = CYCLE_KASKADE       !< module stencil_mg's cycle
    integer :: sweeps = 1                  !< symmetric Gauss-Seidel sweeps per smoothing (>= 1)
    integer :: levels = 0                  !< most levels (0: as many as fit)
    integer :: product = PRODUCT_FUSED     !< the product with S: PRODUCT_DOUBLE, _MIXED or _FUSED
    integer :: coarse = COARSE_AUTO        !< the coarse levels: COARSE_AUTO, _REDISCRETIZE or _GALERKIN
    integer :: gather = GATHER_AUTO        !< thin coarse levels on many ranks: GATHER_AUTO or GATHER_NEVER
    logical :: given = .false.             !< one of the cycle's options was given
  end type mg_options_t

  !> nuno's multigrid and S by stencil offset.
  type :: mg_glue_t
    private
    type(lattice_t), pointer :: lat => null()
    type(tDM) :: da3                       !< dof 3 (not owned)
    type(tKSP) :: ksp                      !< the inner solver (not owned)
    type(stencil_mg_t) :: mg
    logical :: built = .false.             !< its coarse levels exist
    logical :: rediscretize = .false.      !< the coarse levels are the cloth on the coarse lattices (mc), not Galerkin products
    type(mg_coarse_t) :: mc                !< those lattices and states (module mg_coarse)
    PetscLogEvent :: ev_galerkin = 0       !< the multigrid's coarse levels and coarsest factorisation
    PetscLogEvent :: ev_cycle = 0          !< one multigrid cycle
    real(rp), allocatable :: st(:, :, :, :, :) !< (0:nx-1, 3, 3, offset_count(w), 0:nrow-1) S by stencil offset, nodes fastest (module offset_product): rows ys..ye, or with the mixed product a ring of 2w - 1 rows (module reduced_assembly)
    ! The product with S from the multigrid's finest level (single-precision
    ! blocks in difference form, double-precision vectors; -nuno_mg_product)
    logical :: mixed_product = .false.
    ! The fused product (-nuno_mg_product fused): each multigrid cycle forms
    ! the product of its output z with S in its last sweep (pax); the
    ! Krylov method's next product is of z (FGMRES: w = S M^{-1} v), and
    ! stencil_mult returns pax while z is that same vector, unchanged
    ! (its PETSc object state).
    logical :: fused_product = .false.
    type(tVec) :: pax                      !< 3-dof: S z of the last cycle's output z
    type(tVec) :: pax_of                   !< z (the handle, not a reference)
    integer(c_int64_t) :: pax_state = -1   !< z's object state when pax was formed
    logical :: pax_valid = .false.         !< pax is S z for the current S
    logical :: pax_checked = .false.       !< the Krylov method's side checked (at the first cycle), pax made
    integer :: pax_used = 0                !< products returned from pax (-reduced_ksp_view)
    ! The process models' pair blocks (self-contact: nodes that are not
    ! stencil neighbours), which every product adds after the stencil's
    type(pm_list_t), pointer :: pms => null()  !< the run's process models (not owned; null: none)
    real(rp) :: a = 0.0_rp                 !< shift of the assembled S [1/time]
  end type mg_glue_t

  interface
    !> src/solver/nuno_vec_state.c: PetscObjectStateGet (no Fortran stub in 3.18).
    integer(c_int) function nuno_object_state(obj, state) bind(C, name='nuno_object_state')
      import :: c_int, c_intptr_t, c_int64_t
      integer(c_intptr_t) :: obj            !< the handle (tVec%v, ...), passed as PetscObject*
      integer(c_int64_t), intent(out) :: state
    end function nuno_object_state
    !> src/solver/nuno_options.c: the options of nuno's multigrid (-nuno_mg ...);
    !> the choices as codes of the lists passed (module solver_choices).
    integer(c_int) function nuno_mg_options_read(fcomm, impl_names, impl_n, impl_len, impl, &
                                                 cycle_names, cycle_n, cycle_len, cycle, sweeps, levels, &
                                                 product_names, product_n, product_len, product, &
                                                 coarse_names, coarse_n, coarse_len, coarse, given) &
        bind(C, name='nuno_mg_options_read')
      import :: c_int, c_char
      integer(c_int), value :: fcomm, impl_n, impl_len, cycle_n, cycle_len, product_n, product_len, coarse_n, coarse_len
      character(kind=c_char), intent(in) :: impl_names(*), cycle_names(*), product_names(*), coarse_names(*)
      integer(c_int), intent(inout) :: impl, cycle, sweeps, levels, product, coarse
      integer(c_int), intent(out) :: given
    end function nuno_mg_options_read
    !> src/solver/nuno_options.c: -nuno_mg_gather as a code of names.
    integer(c_int) function nuno_mg_gather_read(fcomm, names, n, len, gather, given) bind(C, name='nuno_mg_gather_read')
      import :: c_int, c_char
      integer(c_int), value :: fcomm, n, len
      character(kind=c_char), intent(in) :: names(*)
      integer(c_int), intent(inout) :: gather
      integer(c_int), intent(out) :: given
    end function nuno_mg_gather_read
  end interface

contains

  !> S by stencil offset (mg_glue_assemble), its product the MATSHELL s:
  !> nuno's multigrid needs no PETSc matrix, and no column indices are
  !> stored (1.2 KB a node with bending against 2.6 in AIJ, and with the
  !> mixed product only a ring of rows: 648 B a node in the multigrid's
  !> finest level instead). nx x ny lattice, n owned rows, halo w.
  !> Collective.
  subroutine mg_glue_matrix(gl, lat, da3, ksp, nx, ny, n, w, product, ev_galerkin, ev_cycle, s, ierr)
    type(mg_glue_t), intent(inout), target :: gl
    type(lattice_t), intent(in), target :: lat
    type(tDM), intent(in) :: da3
    type(tKSP), intent(in) :: ksp
    PetscInt, intent(in) :: nx, ny, n, w
    integer, intent(in) :: product                 !< the product with S (-nuno_mg_product): PRODUCT_DOUBLE, _MIXED or _FUSED
    PetscLogEvent, intent(in) :: ev_galerkin, ev_cycle
    type(tMat), intent(out) :: s
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: m, mg
    MPI_Comm :: comm
    gl%lat => lat
    gl%da3 = da3
    gl%ksp = ksp
    ! fused: mixed, each cycle's output multiplied in its last sweep, where
    ! the Krylov method multiplies that output (checked at the first cycle,
    ! mg_pc_apply)
    gl%mixed_product = product /= PRODUCT_DOUBLE
    gl%fused_product = product == PRODUCT_FUSED
    gl%ev_galerkin = ev_galerkin
    gl%ev_cycle = ev_cycle
    PetscCall(PetscObjectGetComm(da3, comm, ierr))
    ! the whole strip for the product in double precision; with the mixed
    ! product only the rows the assembly is writing (a ring: with bending
    ! the triples reach two rows back; module reduced_assembly)
    if (gl%mixed_product) then
      allocate(gl%st(0:nx - 1, 3, 3, offset_count(w), 0:2 * w - 2))
    else
      allocate(gl%st(0:nx - 1, 3, 3, offset_count(w), 0:n - 1))
    end if
    gl%st = 0.0_rp
    m = 3 * nx * n
    mg = 3 * nx * ny
    PetscCall(MatCreateShell(comm, m, m, mg, mg, PETSC_NULL_INTEGER, s, ierr))
    PetscCall(MatShellSetContext(s, gl, ierr))
    PetscCall(MatShellSetOperation(s, MATOP_MULT, stencil_mult, ierr))
  end subroutine mg_glue_matrix

  !> nuno's multigrid as the inner KSP's PCSHELL pc: levels up to
  !> max_levels, interpolation interp (INTERP_*), cycle and sweeps of
  !> module stencil_mg; rows ys..ys+n-1 of the nx x ny lattice, halo w;
  !> paired: S(p, q) = S(q, p) block for block. Collective.
  subroutine mg_glue_pc(gl, pc, nx, ny, ys, n, w, interp, max_levels, cycle, sweeps, coarse, paired, gather, ierr)
    type(mg_glue_t), intent(inout), target :: gl
    type(tPC), intent(inout) :: pc
    PetscInt, intent(in) :: nx, ny, ys, n, w
    integer, intent(in) :: interp, max_levels, cycle, sweeps
    integer, intent(in) :: coarse                  !< the coarse levels (-nuno_mg_coarse): COARSE_AUTO, _REDISCRETIZE or _GALERKIN
    logical, intent(in) :: paired
    logical, intent(in) :: gather                  !< thin coarse levels gathered on fewer ranks (-nuno_mg_gather auto)
    PetscErrorCode, intent(out) :: ierr
    logical :: cubic(10), cubic_up(10)
    integer :: l
    MPI_Comm :: comm
    ! auto: rediscretised with bending (paired: no bending), where the
    ! bilinear Galerkin product doubles the bending on every level (hang
    ! 257: 0.82x the time a step); Galerkin without, where the
    ! rediscretised levels took 8-30 % more cycles for the same time
    ! within the noise (docs/performance.md, "The multigrid with bending")
    gl%rediscretize = coarse == COARSE_REDISCRETIZE .or. (coarse == COARSE_AUTO .and. .not. paired)
    ! Transfer l joins level l + 1 to level l (1 = the lattice).
    ! coarse_cubic: the finest level's coarse correction interpolated
    ! cubic too, its restriction and Galerkin product bilinear (module
    ! stencil_mg, mg_create).
    do l = 1, size(cubic)
      cubic(l) = interp == INTERP_CUBIC .or. (interp == INTERP_COARSE_CUBIC .and. l > 1)
      cubic_up(l) = interp == INTERP_CUBIC .or. interp == INTERP_COARSE_CUBIC
    end do
    ! rediscretised: coarse_cubic is the restriction bilinear and the
    ! interpolation cubic on every level (a cubic restriction took 15-30 %
    ! more cycles on hang 129..513: docs/performance.md)
    if (gl%rediscretize) cubic = interp == INTERP_CUBIC
    PetscCall(PetscObjectGetComm(gl%da3, comm, ierr))
    call mg_create(gl%mg, comm, nx, ny, ys, ys + n - 1, w, cubic, max_levels, cycle, sweeps, cubic_up, paired=paired, &
                   rediscretize=gl%rediscretize, gather=gather)
    if (gl%rediscretize) call mg_coarse_init(gl%mc, gl%mg, gl%lat, comm)
    PetscCall(PCShellSetContext(pc, gl, ierr))
    PetscCall(PCShellSetApply(pc, mg_pc_apply, ierr))
    PetscCall(PCShellSetName(pc, 'nuno structured multigrid (module stencil_mg)', ierr))
    PetscCall(PCShellSetView(pc, mg_pc_view, ierr))
  end subroutine mg_glue_pc

  !> Free the multigrid and the fused product's vector.
  subroutine mg_glue_free(gl, ierr)
    type(mg_glue_t), intent(inout) :: gl
    PetscErrorCode, intent(out) :: ierr
    ierr = 0
    call mg_coarse_free(gl%mc)
    call mg_destroy(gl%mg)
    if (gl%fused_product .and. gl%pax_checked) then
      PetscCall(VecDestroy(gl%pax, ierr))
    end if
  end subroutine mg_glue_free

  !> The process models whose pair blocks S's product adds (module
  !> process_models' pm_list_pair_product, where some rank has any).
  subroutine mg_glue_set_pairs(gl, pms)
    type(mg_glue_t), intent(inout) :: gl
    type(pm_list_t), intent(in), target :: pms
    gl%pms => pms
  end subroutine mg_glue_set_pairs

  !> S by stencil offset at the ghosted state u (module reduced_assembly's
  !> assemble_stencil, which takes the products g of w and the diagonal kd
  !> on the way), and the multigrid's finest level made from it row by row
  !> (every assembly: its smoother and residual use the current S, as
  !> PETSc's PCMG does with a reused hierarchy).
  subroutine mg_glue_assemble(gl, nodal, u, fixedg, a, damping, clamp, gauss_newton, w, lb, g, kd)
    type(mg_glue_t), intent(inout), target :: gl
    type(node_blocks_t), intent(in) :: nodal
    real(rp), intent(in) :: u(0:, 0:, gl%lat%gys:)
    logical, intent(in) :: fixedg(0:, gl%lat%gys:)
    real(rp), intent(in) :: a
    logical, intent(in) :: damping, clamp, gauss_newton
    real(rp), intent(in) :: w(0:, 0:, gl%lat%gys:)
    real(rp), intent(inout) :: lb(0:, :, :, :, 0:)
    real(rp), intent(out) :: g(:, 0:, gl%lat%ys:)
    real(rp), intent(out) :: kd(:, 0:, gl%lat%ys:)
    type(stencil_t), pointer :: fine
    gl%pax_valid = .false.
    gl%a = a
    fine => mg_fine_level(gl%mg)
    call assemble_stencil(gl%lat, nodal, u, fixedg, a, damping, clamp, gauss_newton, w, lb, g, kd, gl%st, fine)
  end subroutine mg_glue_assemble

  !> The coarse levels exist (mg_coarse_levels ran).
  pure logical function mg_glue_built(gl)
    type(mg_glue_t), intent(in) :: gl
    mg_glue_built = gl%built
  end function mg_glue_built

  !> The multigrid and the product with S, appended to line (the inner
  !> solver's description).
  subroutine mg_glue_describe(gl, line)
    type(mg_glue_t), intent(in) :: gl
    character(len=*), intent(inout) :: line
    character(len=160) :: text(16)
    integer :: n
    call mg_describe(gl%mg, text, n)
    line = trim(line)//' + nuno multigrid: '//trim(text(1)(1:index(text(1), ', single') - 1))// &
           ', '//trim(adjustl(text(n)(index(text(n), 'reads'):index(text(n), ' over') - 1)))
    if (gl%fused_product) then
      line = trim(line)//'; product with S fused (the finest level''s single-precision blocks; of each cycle''s output in its last sweep)'
    else
      line = trim(line)//'; product with S '//trim(merge('mixed (the finest level''s single-precision blocks)', &
                                                           'double                                            ', gl%mixed_product))
    end if
  end subroutine mg_glue_describe

  !> The options of nuno's multigrid (-nuno_mg ...; read in
  !> src/solver/nuno_options.c, where -help shows them) over opt's
  !> defaults, and their checks. Collective.
  subroutine mg_options_read(comm, opt, ierr)
    MPI_Comm, intent(in) :: comm
    type(mg_options_t), intent(out) :: opt
    PetscErrorCode, intent(out) :: ierr
    integer(c_int) :: impl, cycle, sweeps, levels, product, coarse, given, gather, gather_given
    impl = opt%impl
    cycle = opt%cycle
    sweeps = opt%sweeps
    levels = opt%levels
    product = opt%product
    coarse = opt%coarse
    gather = opt%gather
    ierr = nuno_mg_options_read(comm, MG_NAMES, size(MG_NAMES), len(MG_NAMES), impl, &
                                CYCLE_NAMES, size(CYCLE_NAMES), len(CYCLE_NAMES), cycle, sweeps, levels, &
                                PRODUCT_NAMES, size(PRODUCT_NAMES), len(PRODUCT_NAMES), product, &
                                COARSE_NAMES, size(COARSE_NAMES), len(COARSE_NAMES), coarse, given)
    if (ierr /= 0) return
    ierr = nuno_mg_gather_read(comm, GATHER_NAMES, size(GATHER_NAMES), len(GATHER_NAMES), gather, gather_given)
    if (ierr /= 0) return
    if (sweeps < 1) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(comm, ierr, '-nuno_mg_sweeps '//itoa(int(sweeps))//' must be >= 1')
    end if
    if (levels < 0) then
      ierr = PETSC_ERR_ARG_OUTOFRANGE
      SETERRQ(comm, ierr, '-nuno_mg_levels '//itoa(int(levels))//' must be >= 1 (or 0: as many as fit)')
    end if
    opt = mg_options_t(impl=int(impl), cycle=int(cycle), sweeps=int(sweeps), levels=int(levels), &
                       product=int(product), coarse=int(coarse), gather=int(gather), &
                       given=given /= 0 .or. gather_given /= 0)
  end subroutine mg_options_read

  !> Multigrid levels of the lattice: as many as it halves into with at
  !> least 5 nodes a side and, in every strip, the halo width of rows on
  !> the coarsest grid (a level coarsens n -> (n-1)/2 + 1 in each direction).
  integer function levels_that_fit(nx, ny, w, nranks) result(levels)
    PetscInt, intent(in) :: nx, ny, w, nranks
    integer :: mx, my
    levels = 1
    mx = nx
    my = ny
    do while (mod(mx - 1, 2) == 0 .and. mod(my - 1, 2) == 0 .and. (mx - 1) / 2 + 1 >= 5 .and. &
              (my - 1) / 2 + 1 >= max(5, 2 * w * nranks) .and. levels < 10)
      mx = (mx - 1) / 2 + 1
      my = (my - 1) / 2 + 1
      levels = levels + 1
    end do
  end function levels_that_fit

  !> The inner preconditioner when it is not nuno's multigrid, unless
  !> -reduced_pc_type is given: PETSc's geometric multigrid on the DMDA
  !> (Galerkin coarse operators, one SSOR sweep as smoother) with the given
  !> levels; block Jacobi/ILU(0) where fewer than three fit (small
  !> lattices, for which it is the cheaper), or with overlap additive
  !> Schwarz/ILU(0), each strip's block grown by the rows its matrix rows
  !> reach (PETSc's overlap 1; symmetric: the basic variant, for CG).
  !> Block Jacobi drops the blocks between strips: where one is stiff (the
  !> faces' barrier on a link across a strip boundary, orders of magnitude
  !> above the links' own) the preconditioned S has eigenvalues near the
  !> ratio of soft to stiff, and the inner solve stalls at its cap
  !> (docs/contact.md, "Faces and edges"). Set in the options database, so
  !> that -help shows them and every one can be overridden.
  subroutine default_preconditioner(levels, overlap, symmetric, ierr)
    integer, intent(in) :: levels
    logical, intent(in) :: overlap, symmetric
    PetscErrorCode, intent(out) :: ierr
    PetscBool :: set
    character(len=16) :: txt

    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-reduced_pc_type', set, ierr))
    if (set) return
    if (levels < 3 .and. overlap) then
      PetscCall(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-reduced_pc_type', 'asm', ierr))
      if (symmetric) call set_default('-reduced_pc_asm_type', 'basic')
      return
    end if
    if (levels < 3) then
      PetscCall(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-reduced_pc_type', 'bjacobi', ierr))
      return
    end if
    write(txt, '(i0)') levels
    PetscCall(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-reduced_pc_type', 'mg', ierr))
    PetscCall(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-reduced_pc_mg_levels', trim(txt), ierr))
    PetscCall(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-reduced_pc_mg_galerkin', 'pmat', ierr))
    call set_default('-reduced_mg_levels_ksp_type', 'richardson')
    call set_default('-reduced_mg_levels_pc_type', 'sor')
    call set_default('-reduced_mg_levels_ksp_max_it', '1')
  contains
    subroutine set_default(name, value)
      character(len=*), intent(in) :: name, value
      PetscBool :: given
      call PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, name, given, ierr)
      if (.not. given) call PetscOptionsSetValue(PETSC_NULL_OPTIONS, name, value, ierr)
    end subroutine set_default
  end subroutine default_preconditioner

  !> The multigrid's coarse operators and coarsest factorisation: the
  !> cloth rediscretised on the coarse lattices at the ghosted state
  !> u(0:5, 0:nx-1, gys:gye) with the constrained nodes fixedg, the shift
  !> a and the element flags of the finest level's assembly, with the
  !> node blocks nodal restricted (module mg_coarse), or Galerkin products
  !> of the finest level (module stencil_mg). Collective.
  subroutine mg_coarse_levels(gl, nodal, u, fixedg, a, damping, clamp, gauss_newton, ierr)
    type(mg_glue_t), intent(inout) :: gl
    type(node_blocks_t), intent(in) :: nodal
    real(rp), intent(in) :: u(0:, 0:, gl%lat%gys:)
    logical, intent(in) :: fixedg(0:, gl%lat%gys:)
    real(rp), intent(in) :: a
    logical, intent(in) :: damping, clamp, gauss_newton
    PetscErrorCode, intent(out) :: ierr
    integer :: info
    MPI_Comm :: comm
    PetscCall(PetscLogEventBegin(gl%ev_galerkin, ierr))
    if (gl%rediscretize) then
      call mg_coarse_build(gl%mc, gl%mg, gl%lat, nodal, u, fixedg, a, damping, clamp, gauss_newton, info)
    else
      call mg_build_coarse(gl%mg, info)
    end if
    PetscCall(PetscLogEventEnd(gl%ev_galerkin, ierr))
    gl%built = .true.
    ierr = 0
    if (info /= 0) then
      PetscCall(PetscObjectGetComm(gl%da3, comm, ierr))
      ierr = PETSC_ERR_MAT_LU_ZRPVT
      SETERRQ(comm, ierr, 'nuno: the coarsest multigrid matrix is singular')
    end if
  end subroutine mg_coarse_levels

  !> MATSHELL mult of S: y = S x, one halo exchange of x (none on a rank
  !> that owns every row), then by default
  !> from the multigrid's finest level (single-precision blocks in
  !> difference form, double-precision vectors, each offset's products in
  !> single precision and their sum in double: kernel
  !> stencil_product_mixed, half the bytes), or with -nuno_mg_product double
  !> over S in double precision, one vector loop per offset (kernel
  !> offset_product); then, where a process model gave pair blocks
  !> (self-contact), their part (module reduced_pairs' pair_product_add).
  !> The fused product is the stencil's part alone, so it is kept and the
  !> pair part added after it (a cycle's sweeps take no pair blocks).
  !> Collective.
  subroutine stencil_mult(mat, x, y, ierr)
    type(tMat) :: mat
    type(tVec) :: x, y
    PetscErrorCode :: ierr
    type(mg_glue_t), pointer :: gl
    type(c_ptr) :: ctx                     !< the shell's context: the record's address
    PetscCall(MatShellGetContext(mat, ctx, ierr))
    call c_f_pointer(ctx, gl)
    PetscCall(stencil_part(gl, x, y, ierr))
    if (associated(gl%pms)) then
      if (pm_list_pairs_on(gl%pms)) then
        PetscCall(pair_product_add(gl%pms, gl%lat, gl%da3, gl%a, x, y, ierr))
      end if
    end if
  end subroutine stencil_mult

  !> y = the stencil's part of S x (stencil_mult without the pair blocks).
  !> Collective.
  subroutine stencil_part(gl, x, y, ierr)
    type(mg_glue_t), intent(inout) :: gl
    type(tVec) :: x, y
    PetscErrorCode, intent(out) :: ierr
    type(tVec) :: xloc
    PetscScalar, pointer :: xl(:), ya(:)
    logical :: whole
    integer(c_int64_t) :: state
    ierr = 0
    if (gl%pax_valid) then
      ! x the last cycle's output, unchanged: its product is formed
      if (x%v == gl%pax_of%v) then
        ierr = nuno_object_state(x%v, state)
        if (ierr /= 0) return
        if (state == gl%pax_state) then
          PetscCall(VecCopy(gl%pax, y, ierr))
          gl%pax_used = gl%pax_used + 1
          return
        end if
      end if
    end if
    ! a rank that owns every row (one rank) has no halo: x is read in place
    ! (the copy to a local vector was 2 % of a bw step on one rank)
    whole = gl%lat%gys == gl%lat%ys .and. gl%lat%gye == gl%lat%ye
    if (whole) then
      PetscCall(VecGetArrayReadF90(x, xl, ierr))
    else
      PetscCall(DMGetLocalVector(gl%da3, xloc, ierr))
      PetscCall(DMGlobalToLocalBegin(gl%da3, x, INSERT_VALUES, xloc, ierr))
      PetscCall(DMGlobalToLocalEnd(gl%da3, x, INSERT_VALUES, xloc, ierr))
      PetscCall(VecGetArrayReadF90(xloc, xl, ierr))
    end if
    PetscCall(VecGetArrayF90(y, ya, ierr))
    associate (lat => gl%lat)
      if (gl%mixed_product) then
        ! the finest level is made from S at every assembly (mg_glue_assemble)
        call mg_product(gl%mg, lat%gys, lat%gye, xl, ya)
      else
        call stencil_product(lat%nx, lat%ny, lat%ys, lat%ye, lat%gys, lat%gye, lat%halo, gl%st, xl, ya)
      end if
    end associate
    PetscCall(VecRestoreArrayF90(y, ya, ierr))
    if (whole) then
      PetscCall(VecRestoreArrayReadF90(x, xl, ierr))
    else
      PetscCall(VecRestoreArrayReadF90(xloc, xl, ierr))
      PetscCall(DMRestoreLocalVector(gl%da3, xloc, ierr))
    end if
  end subroutine stencil_part

  !> PCSHELL view (-reduced_ksp_view): the hierarchy of nuno's multigrid.
  subroutine mg_pc_view(pc, viewer, ierr)
    type(tPC) :: pc
    type(tPetscViewer) :: viewer
    PetscErrorCode :: ierr
    type(mg_glue_t), pointer :: gl
    character(len=160) :: text(16)
    integer :: n, k
    type(c_ptr) :: ctx                     !< the shell's context: the record's address
    PetscCall(PCShellGetContext(pc, ctx, ierr))
    call c_f_pointer(ctx, gl)
    call mg_describe(gl%mg, text, n)
    do k = 1, n
      PetscCall(PetscViewerASCIIPrintf(viewer, '  '//trim(text(k))//new_line('a'), ierr))
    end do
    if (gl%fused_product) then
      write(text(1), '(a, i0, a)') 'fused product: ', gl%pax_used, ' products with S so far formed in the cycles'' last sweeps'
      PetscCall(PetscViewerASCIIPrintf(viewer, '  '//trim(text(1))//new_line('a'), ierr))
    end if
  end subroutine mg_pc_view

  !> PCSHELL apply of the inner KSP: one cycle of nuno's multigrid.
  subroutine mg_pc_apply(pc, x, y, ierr)
    type(tPC) :: pc
    type(tVec) :: x, y
    PetscErrorCode :: ierr
    type(mg_glue_t), pointer :: gl
    PetscScalar, pointer :: xa(:, :, :), ya(:, :, :), pa(:, :, :)
    PCSide :: side
    logical :: formed
    type(c_ptr) :: ctx                     !< the shell's context: the record's address
    PetscCall(PCShellGetContext(pc, ctx, ierr))
    call c_f_pointer(ctx, gl)
    if (gl%fused_product .and. .not. gl%pax_checked) then
      ! the first cycle: only a Krylov method that multiplies the
      ! preconditioner's output (right preconditioning: FGMRES, GCR,
      ! GMRES with -reduced_ksp_pc_side right) uses the fused product
      PetscCall(KSPGetPCSide(gl%ksp, side, ierr))
      if (side /= PC_RIGHT) then
        gl%fused_product = .false.
      else
        PetscCall(VecDuplicate(y, gl%pax, ierr))
      end if
      gl%pax_checked = .true.
    end if
    gl%pax_valid = .false.
    PetscCall(DMDAVecGetArrayReadF90(gl%da3, x, xa, ierr))
    PetscCall(DMDAVecGetArrayF90(gl%da3, y, ya, ierr))
    PetscCall(PetscLogEventBegin(gl%ev_cycle, ierr))
    if (gl%fused_product) then
      PetscCall(DMDAVecGetArrayF90(gl%da3, gl%pax, pa, ierr))
      call mg_apply(gl%mg, xa, ya, pa, formed)
      PetscCall(DMDAVecRestoreArrayF90(gl%da3, gl%pax, pa, ierr))
    else
      call mg_apply(gl%mg, xa, ya)
    end if
    PetscCall(PetscLogEventEnd(gl%ev_cycle, ierr))
    PetscCall(DMDAVecRestoreArrayF90(gl%da3, y, ya, ierr))
    PetscCall(DMDAVecRestoreArrayReadF90(gl%da3, x, xa, ierr))
    if (gl%fused_product .and. formed) then
      ! y as it is now (after its array was restored) is what pax is S times
      gl%pax_of = y
      ierr = nuno_object_state(y%v, gl%pax_state)
      if (ierr /= 0) return
      gl%pax_valid = .true.
    end if
  end subroutine mg_pc_apply

  !> The multigrid's interpolations from the DMDA hierarchy, given to PCMG
  !> as plain AIJ. The DMDA makes them MAIJ (one scalar operator for the 3
  !> dof), and 3.18's Galerkin product of a sequential AIJ with a MAIJ
  !> (MatPtAPNumeric_SeqAIJ_SeqMAIJ, "first draft only") sorts every row of
  !> A P and scans every row of the product: converted once, the AIJ x AIJ
  !> product is used at every set-up. (In parallel PETSc converts anyway.)
  subroutine mg_interpolations(da3, interp, pc, ierr)
    type(tDM), intent(in) :: da3
    integer, intent(in) :: interp          !< INTERP_LINEAR, _CUBIC or _COARSE_CUBIC
    type(tPC), intent(inout) :: pc
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: nlev, l
    type(tDM), allocatable :: dms(:)
    type(tMat) :: p

    PetscCall(PCMGGetLevels(pc, nlev, ierr))
    if (nlev < 2) return
    allocate(dms(nlev))
    dms(nlev) = da3
    do l = nlev - 1, 1, -1
      PetscCall(DMCoarsen(dms(l + 1), MPI_COMM_NULL, dms(l), ierr))
    end do
    ! PCMG level l (0 = coarsest) is dms(l + 1); its interpolation maps
    ! level l - 1 to level l.
    do l = nlev - 1, 1, -1
      if (interp == INTERP_CUBIC .or. (interp == INTERP_COARSE_CUBIC .and. l < nlev - 1)) then
        PetscCall(cubic_interpolation(dms(l), dms(l + 1), p, ierr))
      else
        PetscCall(DMCreateInterpolation(dms(l), dms(l + 1), p, PETSC_NULL_VEC, ierr))
        PetscCall(MatConvert(p, MATAIJ, MAT_INPLACE_MATRIX, p, ierr))
      end if
      PetscCall(PCMGSetInterpolation(pc, l, p, ierr))
      PetscCall(MatDestroy(p, ierr))
    end do
    do l = 1, nlev - 1
      PetscCall(DMDestroy(dms(l), ierr))
    end do
  end subroutine mg_interpolations

  !> Tensor-product cubic interpolation (module interpolation: 4-point
  !> Lagrange, one-sided at the ends, exact for cubics) from the coarse DMDA
  !> dc to the fine df (2:1, vertex-centred), the same for each of the 3
  !> dof, as AIJ (at most 16 non-zeros a row; rows and columns in the
  !> natural order, which is PETSc's for 1 x P strips). With bending the
  !> bilinear interpolation's coarse correction weakens as the lattice is
  !> refined (iterations grew 4 -> 26 from 65 to 1025); cubic keeps it.
  subroutine cubic_interpolation(dc, df, p, ierr)
    type(tDM), intent(in) :: dc, df
    type(tMat), intent(out) :: p
    PetscErrorCode, intent(out) :: ierr
    PetscInt :: mxc, myc, mxf, myf, xs, ys, zs, xm, ym, zm, cxs, cys, cxm, cym
    PetscInt :: row(1), cols(16), nz, i, j, d, a, b, idum
    PetscInt, parameter :: one = 1
    PetscScalar :: v(16)
    integer :: ncx, ncy, ix(4), iy(4)
    real(rp) :: wx(4), wy(4)
    MPI_Comm :: comm

    PetscCall(PetscObjectGetComm(df, comm, ierr))
    PetscCall(DMDAGetInfo(dc, PETSC_NULL_INTEGER, mxc, myc, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, idum, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, ierr))
    PetscCall(DMDAGetInfo(df, PETSC_NULL_INTEGER, mxf, myf, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, idum, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, ierr))
    PetscCall(DMDAGetCorners(df, xs, ys, zs, xm, ym, zm, ierr))
    PetscCall(DMDAGetCorners(dc, cxs, cys, zs, cxm, cym, zm, ierr))
    PetscCall(MatCreateAIJ(comm, 3 * xm * ym, 3 * cxm * cym, PETSC_DETERMINE, PETSC_DETERMINE, 16, PETSC_NULL_INTEGER, 16, PETSC_NULL_INTEGER, p, ierr))
    PetscCall(MatSetBlockSizes(p, 3, 3, ierr))
    do j = ys, ys + ym - 1
      call cubic_weights(j, myc, iy, wy, ncy)
      do i = xs, xs + xm - 1
        call cubic_weights(i, mxc, ix, wx, ncx)
        do d = 0, 2
          row(1) = 3 * (i + j * mxf) + d
          nz = 0
          do b = 1, ncy
            do a = 1, ncx
              nz = nz + 1
              cols(nz) = 3 * (ix(a) + iy(b) * mxc) + d
              v(nz) = wx(a) * wy(b)
            end do
          end do
          PetscCall(MatSetValues(p, one, row, nz, cols, v, INSERT_VALUES, ierr))
        end do
      end do
    end do
    PetscCall(MatAssemblyBegin(p, MAT_FINAL_ASSEMBLY, ierr))
    PetscCall(MatAssemblyEnd(p, MAT_FINAL_ASSEMBLY, ierr))
  end subroutine cubic_interpolation

  !> Krylov methods that can, stop on the true residual (which is the 6-dof
  !> v-row residual): right preconditioning for the GMRES family, the
  !> unpreconditioned norm for CG-like ones; unless the options say
  !> otherwise.
  subroutine true_residual_defaults(ksp, ierr)
    type(tKSP), intent(inout) :: ksp
    PetscErrorCode, intent(out) :: ierr
    character(len=64) :: ktype
    PetscBool :: side_set, norm_set
    PetscCall(KSPGetType(ksp, ktype, ierr))
    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-reduced_ksp_pc_side', side_set, ierr))
    PetscCall(PetscOptionsHasName(PETSC_NULL_OPTIONS, PETSC_NULL_CHARACTER, '-reduced_ksp_norm_type', norm_set, ierr))
    select case (trim(ktype))
    case (KSPGMRES, KSPFGMRES, KSPLGMRES, KSPDGMRES, KSPPGMRES, KSPBCGS, KSPIBCGS, KSPTFQMR)
      if (.not. side_set .and. trim(ktype) /= KSPFGMRES) then
        PetscCall(KSPSetPCSide(ksp, PC_RIGHT, ierr))
      end if
    case (KSPCG, KSPPIPECG, KSPCR, KSPFCG)
      if (.not. norm_set) then
        PetscCall(KSPSetNormType(ksp, KSP_NORM_UNPRECONDITIONED, ierr))
      end if
    case default
    end select
  end subroutine true_residual_defaults

end module reduced_mg
