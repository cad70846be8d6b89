! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of the option choice lists (module solver_choices): each code
!> names the choice the options and docs call it by (input/README.md,
!> -help), so that a list reordered without its codes fails here; the names
!> of a list are distinct and fit the C options blocks (src/solver/nuno_options.c:
!> at most 8 names of at most 31 characters).
program test_solver_choices
  use solver_choices
  use check, only: check_true, check_report
  implicit none

  call check_true(JACOBIAN_NAMES(JACOBIAN_REDUCED) == 'reduced' .and. JACOBIAN_NAMES(JACOBIAN_FULL) == 'full', '-nuno_jacobian')
  call check_true(INTERP_NAMES(INTERP_AUTO) == 'auto' .and. INTERP_NAMES(INTERP_LINEAR) == 'linear' .and. &
                  INTERP_NAMES(INTERP_CUBIC) == 'cubic' .and. INTERP_NAMES(INTERP_COARSE_CUBIC) == 'coarse_cubic', &
                  '-nuno_mg_interpolation')
  call check_true(GUESS_NAMES(GUESS_AUTO) == 'auto' .and. GUESS_NAMES(GUESS_NONE) == 'none' .and. &
                  GUESS_NAMES(GUESS_PREVIOUS) == 'previous' .and. GUESS_NAMES(GUESS_EXTRAPOLATE) == 'extrapolate' .and. &
                  GUESS_NAMES(GUESS_PROJECT) == 'project', '-nuno_inner_guess')
  call check_true(FALLBACK_NAMES(FALLBACK_NONE) == 'none' .and. FALLBACK_NAMES(FALLBACK_BT) == 'bt' .and. &
                  FALLBACK_NAMES(FALLBACK_L2) == 'l2', '-nuno_linesearch_fallback')
  call check_true(START_NAMES(START_AUTO) == 'auto' .and. START_NAMES(START_LINEAR) == 'linear' .and. &
                  START_NAMES(START_CUBIC) == 'cubic', '-nuno_newton_start')
  call check_true(MG_NAMES(MG_STENCIL) == 'stencil' .and. MG_NAMES(MG_PETSC) == 'petsc', '-nuno_mg')
  call check_true(CYCLE_NAMES(CYCLE_V) == 'v' .and. CYCLE_NAMES(CYCLE_KASKADE) == 'kaskade' .and. CYCLE_NAMES(CYCLE_W) == 'w', &
                  '-nuno_mg_cycle')
  call check_true(COARSE_NAMES(COARSE_AUTO) == 'auto' .and. COARSE_NAMES(COARSE_REDISCRETIZE) == 'rediscretize' .and. &
                  COARSE_NAMES(COARSE_GALERKIN) == 'galerkin', '-nuno_mg_coarse')
  call check_true(PRODUCT_NAMES(PRODUCT_MIXED) == 'mixed' .and. PRODUCT_NAMES(PRODUCT_DOUBLE) == 'double' .and. &
                  PRODUCT_NAMES(PRODUCT_FUSED) == 'fused', '-nuno_mg_product')
  call check_list(JACOBIAN_NAMES, 'JACOBIAN_NAMES')
  call check_list(INTERP_NAMES, 'INTERP_NAMES')
  call check_list(GUESS_NAMES, 'GUESS_NAMES')
  call check_list(FALLBACK_NAMES, 'FALLBACK_NAMES')
  call check_list(START_NAMES, 'START_NAMES')
  call check_list(MG_NAMES, 'MG_NAMES')
  call check_list(CYCLE_NAMES, 'CYCLE_NAMES')
  call check_list(PRODUCT_NAMES, 'PRODUCT_NAMES')
  call check_list(COARSE_NAMES, 'COARSE_NAMES')
  call check_report()

contains

  subroutine check_list(names, what)
    character(len=*), intent(in) :: names(0:)
    character(len=*), intent(in) :: what
    integer :: i, j
    logical :: distinct
    distinct = .true.
    do i = 0, size(names) - 1
      do j = i + 1, size(names) - 1
        if (names(i) == names(j)) distinct = .false.
      end do
    end do
    call check_true(distinct, what//': distinct names')
    call check_true(size(names) <= 8 .and. len(names) <= 31 .and. all(len_trim(names) > 0), what//': fits the C options blocks')
  end subroutine check_list

end program test_solver_choices
