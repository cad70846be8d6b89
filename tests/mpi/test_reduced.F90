! SPDX-License-Identifier: BSD-2-Clause
!> MPI test of the reduced solve (module reduced) on a deformed, moving
!> lattice with constrained nodes, for springs alone, energy bending with
!> bending damping, and paper bending:
!>  1. S y against central finite differences of the forces along
!>     (x, v) + eps (y/a, y): S y = a M y - d/deps f (free rows, y = 0 on
!>     constrained nodes), and S's constrained rows and columns exact;
!>     S by stencil offset (the multigrid's path, whose bending triples go
!>     through the lanes' kernels) against that S, and its element products
!>     against the AIJ path's;
!>  2. the 6-dof MATSHELL against finite differences of the 6-dof residual;
!>  3. the elimination (PCSHELL with an exact inner LU) inverts the MATSHELL:
!>     J (P b) = b, for a general b and for the b = F(u) of a Newton step
!>     (whose products are formed during the assembly);
!>  4. with an inexact inner solve (dv = its right-hand side) the constrained
!>     nodes' rows still hold exactly (du = b / a there).
!> Every error is a global maximum, so every rank checks the same numbers.
program test_reduced
#include "petsc/finclude/petscsnes.h"
#include "petsc/finclude/petscdmda.h"
  use petscsnes
  use petscdmda
  use mpi
  use kinds, only: rp
  use config, only: nuno_config, BEND_NONE, BEND_PAPER, BEND_ENERGY, SPRING_AXIAL, MASS_AREA
  use lattice, only: lattice_t, lattice_init, halo_width, rest_position
  use forces, only: internal_forces
  use reduced, only: reduced_t, reduced_create, reduced_destroy, reduced_assemble, reduced_set_fixed, &
                     reduced_attach, reduced_matrix, reduced_dm, reduced_jacobian, reduced_inner_ksp, &
                     reduced_writes_directly, reduced_use_buffer, reduced_offset_assembly, reduced_products
  use check, only: check_true, check_report
  use node_blocks, only: node_blocks_t
  use mg_kernels, only: stencil_t, stencil_init
  use offset_product, only: stencil_product, offset_count
  implicit none
  PetscErrorCode :: ierr

  PetscCallA(PetscInitialize(ierr))
  ! An exact inner solve, so that the elimination is exact.
  PetscCallA(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-reduced_ksp_type', 'preonly', ierr))
  PetscCallA(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-reduced_pc_type', 'lu', ierr))
  PetscCallA(PetscOptionsSetValue(PETSC_NULL_OPTIONS, '-reduced_pc_factor_mat_solver_type', 'mumps', ierr))
  call run_case(BEND_NONE, 'springs')
  call run_case(BEND_ENERGY, 'energy bending')
  call run_case(BEND_PAPER, 'paper bending')
  call check_report()
  PetscCallA(PetscFinalize(ierr))

contains

  !> Deformed position and velocity of node (i, j): smooth, non-planar,
  !> every link stretched or compressed and turning.
  pure subroutine state_of(lat, i, j, x, v)
    type(lattice_t), intent(in) :: lat
    integer, intent(in) :: i, j
    real(rp), intent(out) :: x(3), v(3)
    real(rp) :: s, t
    s = real(i, rp) / real(lat%nx - 1, rp)
    t = real(j, rp) / real(lat%ny - 1, rp)
    x = rest_position(lat, i, j) + 0.08_rp * [sin(2.0_rp * s + t), cos(3.0_rp * t) * s, 1.5_rp * sin(2.5_rp * s) * cos(2.0_rp * t)]
    v = [0.3_rp * cos(s + 2.0_rp * t), -0.2_rp * s * t, 0.5_rp * sin(3.0_rp * s - t)]
  end subroutine state_of

  !> Global max of |x|.
  real(rp) function gmax(x)
    real(rp), intent(in) :: x
    integer :: mpierr
    call MPI_Allreduce(x, gmax, 1, MPI_DOUBLE_PRECISION, MPI_MAX, PETSC_COMM_WORLD, mpierr)
  end function gmax

  !> Forces at the ghosted state of the global vector uvec (owned rows valid).
  subroutine forces_at(da, lat, uvec, f)
    type(tDM), intent(in) :: da
    type(lattice_t), intent(in) :: lat
    type(tVec), intent(in) :: uvec
    real(rp), intent(out) :: f(:, 0:, lat%gys:)
    type(tVec) :: loc
    PetscScalar, pointer :: u(:, :, :)
    integer :: nbad, bad(2)
    PetscErrorCode :: ierr
    call DMGetLocalVector(da, loc, ierr)
    call DMGlobalToLocalBegin(da, uvec, INSERT_VALUES, loc, ierr)
    call DMGlobalToLocalEnd(da, uvec, INSERT_VALUES, loc, ierr)
    call DMDAVecGetArrayReadF90(da, loc, u, ierr)
    call internal_forces(lat, u, f, nbad, bad)
    call DMDAVecRestoreArrayReadF90(da, loc, u, ierr)
    call DMRestoreLocalVector(da, loc, ierr)
  end subroutine forces_at

  subroutine run_case(bend, label)
    integer, intent(in) :: bend
    character(*), intent(in) :: label
    type(nuno_config) :: cfg
    type(lattice_t), target :: lat
    type(node_blocks_t), target :: nodal   ! none: no contact here
    type(reduced_t), target :: red, red2
    PetscReal :: snorm, dnorm
    type(tDM) :: da6, da3
    type(tMat) :: jac
    type(tVec) :: u, ud, up, um, y3, sy3, sy3b, b, du, jdu
    type(tVec) :: uloc, udloc
    type(tSNES) :: snes
    type(tKSP) :: outer
    PetscScalar, pointer :: ua(:, :, :), uda(:, :, :), ya(:, :, :), sa(:, :, :), sb(:, :, :), pa(:, :, :)
    PetscScalar, pointer :: ba(:, :, :), ja(:, :, :), da(:, :, :), ul(:, :, :), udl(:, :, :)
    PetscInt :: xs, ys, zs, xm, ym, zm, nxp, nyp, w
    PetscInt, parameter :: one = 1, six = 6
    real(rp), allocatable :: fp(:, :, :), fm(:, :, :)
    logical, allocatable :: fixed(:, :)
    real(rp) :: a, eps, x(3), vv(3), err, scale, fd(3), m
    integer :: i, j

    cfg%lattice%nx = 7
    cfg%lattice%ny = 9
    cfg%lattice%lx = 1.3_rp
    cfg%lattice%ly = 1.7_rp
    cfg%lattice%total_mass = 0.3_rp
    cfg%lattice%mass_code = MASS_AREA
    cfg%material%spring_code = SPRING_AXIAL
    cfg%material%e_s = 2.0_rp
    cfg%material%eta_s = 0.3_rp
    cfg%material%e_d = 1.5_rp
    cfg%material%eta_d = 0.2_rp
    cfg%material%bending_code = bend
    cfg%material%k_b = merge(0.01_rp, 0.05_rp, bend == BEND_PAPER)
    cfg%material%eta_b = merge(0.02_rp, 0.0_rp, bend == BEND_ENERGY)
    cfg%lattice%ax = cfg%lattice%lx / real(cfg%lattice%nx - 1, rp)
    cfg%lattice%ay = cfg%lattice%ly / real(cfg%lattice%ny - 1, rp)
    cfg%material%has_damping = .true.
    w = halo_width(cfg)
    nxp = cfg%lattice%nx
    nyp = cfg%lattice%ny
    a = 37.0_rp

    PetscCallA(DMDACreate2d(PETSC_COMM_WORLD, DM_BOUNDARY_NONE, DM_BOUNDARY_NONE, DMDA_STENCIL_BOX, nxp, nyp, one, PETSC_DECIDE, six, w, PETSC_NULL_INTEGER, PETSC_NULL_INTEGER, da6, ierr))
    PetscCallA(DMSetUp(da6, ierr))
    PetscCallA(DMDAGetCorners(da6, xs, ys, zs, xm, ym, zm, ierr))
    call lattice_init(lat, cfg, ys, ys + ym - 1)
    allocate(fp(3, 0:cfg%lattice%nx - 1, lat%gys:lat%gye), fm(3, 0:cfg%lattice%nx - 1, lat%gys:lat%gye))
    allocate(fixed(0:cfg%lattice%nx - 1, lat%ys:lat%ye))

    ! State, its time derivative (any), constrained nodes.
    PetscCallA(DMCreateGlobalVector(da6, u, ierr))
    PetscCallA(VecDuplicate(u, ud, ierr))
    PetscCallA(DMDAVecGetArrayF90(da6, u, ua, ierr))
    PetscCallA(DMDAVecGetArrayF90(da6, ud, uda, ierr))
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        call state_of(lat, i, j, x, vv)
        ua(0:2, i, j) = x
        ua(3:5, i, j) = vv
        uda(:, i, j) = [0.1_rp * i, -0.2_rp * j, 0.3_rp, 0.05_rp * i * j, 0.7_rp, -0.1_rp * i]
        fixed(i, j) = (j == lat%ny - 1 .and. (i == 0 .or. i == lat%nx - 1)) .or. (i == 3 .and. j == 4)
      end do
    end do
    PetscCallA(DMDAVecRestoreArrayF90(da6, ud, uda, ierr))
    PetscCallA(DMDAVecRestoreArrayF90(da6, u, ua, ierr))

    PetscCallA(reduced_create(red, da6, lat, nodal, .false., .false., .false., .true., .false., .false., 1, 0.0_rp, 0, ierr))
    da3 = reduced_dm(red)
    jac = reduced_jacobian(red)
    PetscCallA(reduced_set_fixed(red, fixed, ierr))
    PetscCallA(DMGetLocalVector(da6, uloc, ierr))
    PetscCallA(DMGetLocalVector(da6, udloc, ierr))
    PetscCallA(DMGlobalToLocalBegin(da6, u, INSERT_VALUES, uloc, ierr))
    PetscCallA(DMGlobalToLocalEnd(da6, u, INSERT_VALUES, uloc, ierr))
    PetscCallA(DMGlobalToLocalBegin(da6, ud, INSERT_VALUES, udloc, ierr))
    PetscCallA(DMGlobalToLocalEnd(da6, ud, INSERT_VALUES, udloc, ierr))
    PetscCallA(DMDAVecGetArrayReadF90(da6, uloc, ul, ierr))
    PetscCallA(DMDAVecGetArrayReadF90(da6, udloc, udl, ierr))
    PetscCallA(reduced_assemble(red, ul, udl, a, ierr))
    ! S is AIJ here (LU): its values are written straight into the arrays,
    ! element by element (module reduced_assembly). The S of the block
    ! buffer through MatSetValues sums the same terms in another order: the
    ! two must agree to round-off, on every rank count.
    call check_true(reduced_writes_directly(red), label//': AIJ S is written directly')
    PetscCallA(reduced_create(red2, da6, lat, nodal, .false., .false., .false., .true., .false., .false., 1, 0.0_rp, 0, ierr))
    call reduced_use_buffer(red2)
    PetscCallA(reduced_set_fixed(red2, fixed, ierr))
    PetscCallA(reduced_assemble(red2, ul, udl, a, ierr))
    PetscCallA(MatNorm(reduced_matrix(red2), NORM_FROBENIUS, snorm, ierr))
    PetscCallA(MatAXPY(reduced_matrix(red2), -1.0_rp, reduced_matrix(red), SAME_NONZERO_PATTERN, ierr))
    PetscCallA(MatNorm(reduced_matrix(red2), NORM_FROBENIUS, dnorm, ierr))
    if (dnorm > 1.0e-14_rp * snorm) print '(a, es10.2)', ' relative difference ', dnorm / snorm
    call check_true(dnorm <= 1.0e-14_rp * snorm .and. snorm > 0.0_rp, label//': direct S equals the MatSetValues S')
    PetscCallA(reduced_destroy(red2, ierr))
    PetscCallA(DMDAVecRestoreArrayReadF90(da6, udloc, udl, ierr))
    PetscCallA(DMDAVecRestoreArrayReadF90(da6, uloc, ul, ierr))
    PetscCallA(DMRestoreLocalVector(da6, udloc, ierr))
    PetscCallA(DMRestoreLocalVector(da6, uloc, ierr))

    ! 1. S y against finite differences (y = 0 on constrained nodes).
    PetscCallA(DMCreateGlobalVector(da3, y3, ierr))
    PetscCallA(VecDuplicate(y3, sy3, ierr))
    PetscCallA(VecDuplicate(y3, sy3b, ierr))
    PetscCallA(DMDAVecGetArrayF90(da3, y3, ya, ierr))
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        ya(:, i, j) = [sin(1.0_rp + i + 2.0_rp * j), cos(0.5_rp * i - j), sin(0.3_rp * i * j + 0.2_rp)]
        if (fixed(i, j)) ya(:, i, j) = 0.0_rp
      end do
    end do
    PetscCallA(DMDAVecRestoreArrayF90(da3, y3, ya, ierr))
    PetscCallA(MatMult(reduced_matrix(red), y3, sy3, ierr))
    eps = 1.0e-6_rp
    PetscCallA(VecDuplicate(u, up, ierr))
    PetscCallA(VecDuplicate(u, um, ierr))
    PetscCallA(DMDAVecGetArrayReadF90(da3, y3, ya, ierr))
    PetscCallA(DMDAVecGetArrayReadF90(da6, u, ua, ierr))
    PetscCallA(DMDAVecGetArrayF90(da6, up, pa, ierr))
    pa = ua
    pa(0:2, :, lat%ys:lat%ye) = pa(0:2, :, lat%ys:lat%ye) + eps / a * ya(0:2, :, lat%ys:lat%ye)
    pa(3:5, :, lat%ys:lat%ye) = pa(3:5, :, lat%ys:lat%ye) + eps * ya(0:2, :, lat%ys:lat%ye)
    PetscCallA(DMDAVecRestoreArrayF90(da6, up, pa, ierr))
    PetscCallA(DMDAVecGetArrayF90(da6, um, pa, ierr))
    pa = ua
    pa(0:2, :, lat%ys:lat%ye) = pa(0:2, :, lat%ys:lat%ye) - eps / a * ya(0:2, :, lat%ys:lat%ye)
    pa(3:5, :, lat%ys:lat%ye) = pa(3:5, :, lat%ys:lat%ye) - eps * ya(0:2, :, lat%ys:lat%ye)
    PetscCallA(DMDAVecRestoreArrayF90(da6, um, pa, ierr))
    PetscCallA(DMDAVecRestoreArrayReadF90(da6, u, ua, ierr))
    call forces_at(da6, lat, up, fp)
    call forces_at(da6, lat, um, fm)
    err = 0.0_rp
    scale = 0.0_rp
    PetscCallA(DMDAVecGetArrayReadF90(da3, sy3, sa, ierr))
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        m = lat%mass(i, j)
        if (fixed(i, j)) then
          fd = a * m * ya(0:2, i, j)
        else
          fd = a * m * ya(0:2, i, j) - (fp(:, i, j) - fm(:, i, j)) / (2.0_rp * eps)
        end if
        err = max(err, maxval(abs(sa(0:2, i, j) - fd)))
        scale = max(scale, maxval(abs(fd)))
      end do
    end do
    PetscCallA(DMDAVecRestoreArrayReadF90(da3, sy3, sa, ierr))
    PetscCallA(DMDAVecRestoreArrayReadF90(da3, y3, ya, ierr))
    err = gmax(err)
    scale = gmax(scale)
    call check_true(scale > 0.0_rp .and. err <= 1.0e-7_rp * scale, label//': S y against finite differences')
    if (err > 1.0e-7_rp * scale) write(*, '(a,es10.3,a,es10.3)') label//': |S y - fd| = ', err, ' of ', scale
    call check_stencil_s(red, da6, lat, u, y3, sy3, label)

    ! Constrained columns and rows: changing y on constrained nodes changes
    ! S y only there, by a m dy.
    PetscCallA(DMDAVecGetArrayF90(da3, y3, ya, ierr))
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) ya(:, i, j) = [1.0_rp, -2.0_rp, 3.0_rp]
      end do
    end do
    PetscCallA(DMDAVecRestoreArrayF90(da3, y3, ya, ierr))
    PetscCallA(MatMult(reduced_matrix(red), y3, sy3b, ierr))
    PetscCallA(DMDAVecGetArrayReadF90(da3, sy3, sa, ierr))
    PetscCallA(DMDAVecGetArrayReadF90(da3, sy3b, sb, ierr))
    err = 0.0_rp
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) then
          fd = sa(0:2, i, j) + a * lat%mass(i, j) * [1.0_rp, -2.0_rp, 3.0_rp]
        else
          fd = sa(0:2, i, j)
        end if
        err = max(err, maxval(abs(sb(0:2, i, j) - fd)))
      end do
    end do
    PetscCallA(DMDAVecRestoreArrayReadF90(da3, sy3b, sb, ierr))
    PetscCallA(DMDAVecRestoreArrayReadF90(da3, sy3, sa, ierr))
    err = gmax(err)
    call check_true(err <= 1.0e-12_rp * scale, label//': constrained rows and columns of S')

    ! 2. The MATSHELL J du against finite differences of the 6-dof residual
    !    (x-rows a dx - dv, v-rows a dv - d/deps f / m; a du when constrained).
    PetscCallA(VecDuplicate(u, b, ierr))
    PetscCallA(VecDuplicate(u, du, ierr))
    PetscCallA(VecDuplicate(u, jdu, ierr))
    PetscCallA(DMDAVecGetArrayF90(da6, du, da, ierr))
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        da(:, i, j) = [cos(0.7_rp * i + j), sin(i - 0.4_rp * j), 0.5_rp, sin(0.2_rp * i * j), -0.3_rp, cos(real(i + j, rp))]
      end do
    end do
    PetscCallA(DMDAVecRestoreArrayF90(da6, du, da, ierr))
    PetscCallA(MatMult(jac, du, jdu, ierr))
    PetscCallA(VecWAXPY(up, eps, du, u, ierr))
    PetscCallA(VecWAXPY(um, -eps, du, u, ierr))
    call forces_at(da6, lat, up, fp)
    call forces_at(da6, lat, um, fm)
    PetscCallA(DMDAVecGetArrayReadF90(da6, du, da, ierr))
    PetscCallA(DMDAVecGetArrayReadF90(da6, jdu, ja, ierr))
    err = 0.0_rp
    scale = 0.0_rp
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        if (fixed(i, j)) then
          err = max(err, maxval(abs(ja(:, i, j) - a * da(:, i, j))))
        else
          err = max(err, maxval(abs(ja(0:2, i, j) - (a * da(0:2, i, j) - da(3:5, i, j)))))
          fd = a * da(3:5, i, j) - (fp(:, i, j) - fm(:, i, j)) / (2.0_rp * eps * lat%mass(i, j))
          err = max(err, maxval(abs(ja(3:5, i, j) - fd)))
          scale = max(scale, maxval(abs(fd)))
        end if
      end do
    end do
    PetscCallA(DMDAVecRestoreArrayReadF90(da6, jdu, ja, ierr))
    PetscCallA(DMDAVecRestoreArrayReadF90(da6, du, da, ierr))
    err = gmax(err)
    scale = gmax(scale)
    call check_true(scale > 0.0_rp .and. err <= 1.0e-7_rp * scale, label//': 6-dof Jacobian action against finite differences')
    if (err > 1.0e-7_rp * scale) write(*, '(a,es10.3,a,es10.3)') label//': |J du - fd| = ', err, ' of ', scale

    ! 3. Elimination with an exact inner solve inverts J: a general b ...
    PetscCallA(SNESCreate(PETSC_COMM_WORLD, snes, ierr))
    PetscCallA(reduced_attach(red, snes, ierr))
    PetscCallA(SNESGetKSP(snes, outer, ierr))
    PetscCallA(KSPSetOperators(outer, jac, jac, ierr))
    call general_b(da6, lat, b)
    call check_inverse(outer, jac, b, du, jdu, label//': elimination inverts J, general b')
    ! ... and b = F(u) as in a Newton step: F_x = xdot - v everywhere,
    ! F_v = vdot on constrained nodes (free F_v arbitrary).
    PetscCallA(DMDAVecGetArrayF90(da6, b, ba, ierr))
    PetscCallA(DMDAVecGetArrayReadF90(da6, u, ua, ierr))
    PetscCallA(DMDAVecGetArrayReadF90(da6, ud, uda, ierr))
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        ba(0:2, i, j) = uda(0:2, i, j) - ua(3:5, i, j)
        if (fixed(i, j)) ba(3:5, i, j) = uda(3:5, i, j)
      end do
    end do
    PetscCallA(DMDAVecRestoreArrayReadF90(da6, ud, uda, ierr))
    PetscCallA(DMDAVecRestoreArrayReadF90(da6, u, ua, ierr))
    PetscCallA(DMDAVecRestoreArrayF90(da6, b, ba, ierr))
    call check_inverse(outer, jac, b, du, jdu, label//': elimination inverts J, b = F(u)')
    PetscCallA(VecScale(b, -1.0_rp, ierr))
    call check_inverse(outer, jac, b, du, jdu, label//': elimination inverts J, b = -F(u)')

    ! 4. Constrained nodes exact whatever the inner solve: with dv = rhs
    ! inside (preonly, no preconditioner), J (P b) = b holds on the
    ! constrained nodes' rows to round-off (du = b / a there), not on the
    ! free ones, for a b that is not zero on the constrained nodes.
    block
      type(tPC) :: ipc
      PetscScalar, pointer :: ra(:, :, :)
      real(rp) :: efix, efree, bmax
      PetscCallA(KSPGetPC(reduced_inner_ksp(red), ipc, ierr))
      PetscCallA(PCSetType(ipc, PCNONE, ierr))
      call general_b(da6, lat, b)
      PetscCallA(KSPSolve(outer, b, du, ierr))
      PetscCallA(MatMult(jac, du, jdu, ierr))
      PetscCallA(VecAXPY(jdu, -1.0_rp, b, ierr))
      PetscCallA(VecNorm(b, NORM_INFINITY, bmax, ierr))
      efix = 0.0_rp
      efree = 0.0_rp
      PetscCallA(DMDAVecGetArrayReadF90(da6, jdu, ra, ierr))
      do j = lat%ys, lat%ye
        do i = 0, lat%nx - 1
          if (fixed(i, j)) then
            efix = max(efix, maxval(abs(ra(:, i, j))))
          else
            efree = max(efree, maxval(abs(ra(:, i, j))))
          end if
        end do
      end do
      PetscCallA(DMDAVecRestoreArrayReadF90(da6, jdu, ra, ierr))
      efix = gmax(efix)
      efree = gmax(efree)
      call check_true(efix <= 1.0e-13_rp * bmax, label//': constrained nodes exact with an inexact inner solve')
      call check_true(efree > 1.0e-6_rp * bmax, label//': (that inner solve is inexact on the free nodes)')
      if (efix > 1.0e-13_rp * bmax) write(*, '(a,es10.3,a,es10.3)') label//': constrained |J P b - b| = ', efix, ' of ', bmax
    end block

    PetscCallA(SNESDestroy(snes, ierr))
    PetscCallA(VecDestroy(jdu, ierr))
    PetscCallA(VecDestroy(du, ierr))
    PetscCallA(VecDestroy(b, ierr))
    PetscCallA(VecDestroy(um, ierr))
    PetscCallA(VecDestroy(up, ierr))
    PetscCallA(VecDestroy(sy3b, ierr))
    PetscCallA(VecDestroy(sy3, ierr))
    PetscCallA(VecDestroy(y3, ierr))
    PetscCallA(reduced_destroy(red, ierr))
    PetscCallA(VecDestroy(ud, ierr))
    PetscCallA(VecDestroy(u, ierr))
    PetscCallA(DMDestroy(da6, ierr))

  end subroutine run_case

  !> S written by stencil offset (assemble_stencil, the default
  !> multigrid path: bending triples through add_triple_lanes, links row by
  !> row) at the state of red's last assembly: S y by stencil_product
  !> against sy = S y of the AIJ S (checked against finite differences
  !> above, written element by element), and the element products g and
  !> diagonals kd against the AIJ assembly's (gpred, kd).
  subroutine check_stencil_s(red, da6, lat, u, y3, sy, label)
    type(reduced_t), intent(in) :: red
    type(tDM), intent(in) :: da6
    type(lattice_t), intent(in) :: lat
    type(tVec), intent(in) :: u, y3, sy
    character(*), intent(in) :: label
    real(rp), allocatable :: st(:, :, :, :, :), g(:, :, :), kd(:, :, :), ys(:, :, :), yg(:, :, :)
    real(rp), allocatable :: gpred(:, :, :), kdpred(:, :, :)
    type(tDM) :: da3
    type(tVec) :: uloc, yloc
    PetscScalar, pointer :: ul(:, :, :), yl(:, :, :), sa(:, :, :)
    PetscInt :: gxs, gys, gzs, gxm, gym, gzm
    real(rp) :: err, scale, errg, scaleg
    type(stencil_t) :: fine
    PetscErrorCode :: ierr

    call stencil_init(fine, lat%nx, lat%ny, lat%ys, lat%ye, lat%halo, lines=.true.)
    allocate(st(0:lat%nx - 1, 3, 3, offset_count(lat%halo), 0:lat%ye - lat%ys))
    allocate(g(3, 0:lat%nx - 1, lat%ys:lat%ye), kd(3, 0:lat%nx - 1, lat%ys:lat%ye))
    allocate(gpred(3, 0:lat%nx - 1, lat%ys:lat%ye), kdpred(3, 0:lat%nx - 1, lat%ys:lat%ye))
    da3 = reduced_dm(red)
    call reduced_products(red, gpred, kdpred)
    allocate(ys(3, 0:lat%nx - 1, lat%ys:lat%ye), yg(3, 0:lat%nx - 1, lat%gys:lat%gye))
    PetscCallA(DMGetLocalVector(da6, uloc, ierr))
    PetscCallA(DMGlobalToLocalBegin(da6, u, INSERT_VALUES, uloc, ierr))
    PetscCallA(DMGlobalToLocalEnd(da6, u, INSERT_VALUES, uloc, ierr))
    PetscCallA(DMDAVecGetArrayReadF90(da6, uloc, ul, ierr))
    call reduced_offset_assembly(red, ul, st, fine, g, kd)
    PetscCallA(DMDAVecRestoreArrayReadF90(da6, uloc, ul, ierr))
    PetscCallA(DMRestoreLocalVector(da6, uloc, ierr))
    PetscCallA(DMGetLocalVector(da3, yloc, ierr))
    PetscCallA(DMGlobalToLocalBegin(da3, y3, INSERT_VALUES, yloc, ierr))
    PetscCallA(DMGlobalToLocalEnd(da3, y3, INSERT_VALUES, yloc, ierr))
    PetscCallA(DMDAGetGhostCorners(da3, gxs, gys, gzs, gxm, gym, gzm, ierr))
    call check_true(gys <= lat%gys .and. gys + gym - 1 >= lat%gye, label//': the 3-dof ghost rows hold the lattice''s')
    PetscCallA(DMDAVecGetArrayReadF90(da3, yloc, yl, ierr))
    yg = yl(0:2, :, lat%gys:lat%gye)
    PetscCallA(DMDAVecRestoreArrayReadF90(da3, yloc, yl, ierr))
    PetscCallA(DMRestoreLocalVector(da3, yloc, ierr))
    call stencil_product(lat%nx, lat%ny, lat%ys, lat%ye, lat%gys, lat%gye, lat%halo, st, yg, ys)
    PetscCallA(DMDAVecGetArrayReadF90(da3, sy, sa, ierr))
    err = gmax(maxval(abs(ys - sa(0:2, :, lat%ys:lat%ye))))
    scale = gmax(maxval(abs(sa(0:2, :, lat%ys:lat%ye))))
    PetscCallA(DMDAVecRestoreArrayReadF90(da3, sy, sa, ierr))
    call check_true(scale > 0.0_rp .and. err <= 1.0e-12_rp * scale, label//': S by stencil offset equals the AIJ S')
    if (.not. err <= 1.0e-12_rp * scale) write(*, '(a,es10.3,a,es10.3)') label//': |S_st y - S y| = ', err, ' of ', scale
    errg = gmax(max(maxval(abs(g - gpred)), maxval(abs(kd - kdpred))))
    scaleg = gmax(max(maxval(abs(gpred)), maxval(abs(kdpred))))
    call check_true(scaleg > 0.0_rp .and. errg <= 1.0e-12_rp * scaleg, label//': the stencil assembly''s products equal the AIJ''s')
  end subroutine check_stencil_s

  !> A right-hand side with no structure: nonzero in every row, the
  !> constrained nodes' included.
  subroutine general_b(da6, lat, b)
    type(tDM), intent(in) :: da6
    type(lattice_t), intent(in) :: lat
    type(tVec), intent(in) :: b
    PetscScalar, pointer :: ba(:, :, :)
    integer :: i, j
    PetscCallA(DMDAVecGetArrayF90(da6, b, ba, ierr))
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        ba(:, i, j) = [sin(real(i * j, rp)), 0.3_rp * i, -0.2_rp * j, cos(real(i - j, rp)), 0.1_rp, sin(real(i, rp))]
      end do
    end do
    PetscCallA(DMDAVecRestoreArrayF90(da6, b, ba, ierr))
  end subroutine general_b

  !> ||J (P b) - b|| <= 1e-10 ||b|| with P the outer KSP (preonly + elimination).
  subroutine check_inverse(outer, jac, b, du, jdu, what)
    type(tKSP), intent(in) :: outer
    type(tMat), intent(in) :: jac
    type(tVec), intent(in) :: b, du, jdu
    character(*), intent(in) :: what
    real(rp) :: rn, bn
    PetscCallA(KSPSolve(outer, b, du, ierr))
    PetscCallA(MatMult(jac, du, jdu, ierr))
    PetscCallA(VecAXPY(jdu, -1.0_rp, b, ierr))
    PetscCallA(VecNorm(jdu, NORM_INFINITY, rn, ierr))
    PetscCallA(VecNorm(b, NORM_INFINITY, bn, ierr))
    call check_true(bn > 0.0_rp .and. rn <= 1.0e-10_rp * bn, what)
    if (rn > 1.0e-10_rp * bn) write(*, '(a,es10.3,a,es10.3)') what//': |J P b - b| = ', rn, ' of ', bn
  end subroutine check_inverse

end program test_reduced
