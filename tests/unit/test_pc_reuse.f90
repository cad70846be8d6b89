! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of the preconditioner reuse rule (module pc_reuse): the lag
!> counts assemblies; a solve whose cycles per decade pass growth times the
!> first counted solve's after a rebuild asks for a rebuild at the next
!> assembly; solves of fewer than MIN_DECADES decades, solves converged by
!> another test and growth 0 never do; the rule does not depend on the
!> rtol of the solve (the Newton forcing changes it from solve to solve).
program test_pc_reuse
  use kinds, only: rp
  use pc_reuse, only: pc_reuse_t, reuse_init, reuse_due, reuse_rebuilt, reuse_force, reuse_watch, reuse_grown, &
                      cycles_per_decade, PAIRS_PC_LAG
  use check, only: check_true, check_close, check_report
  implicit none
  type(pc_reuse_t) :: r
  logical :: due
  integer :: k

  call check_close(cycles_per_decade(6, 1.0e-3_rp), 2.0_rp, 1.0e-14_rp, 0.0_rp, '6 cycles for 3 decades')

  ! The lag alone: the first assembly rebuilds, then every third.
  call reuse_init(r, 3, 0.0_rp)
  call reuse_due(r, .false., due)
  call check_true(due, 'the first assembly rebuilds')
  call reuse_rebuilt(r)
  do k = 1, 2
    call reuse_due(r, .false., due)
    call check_true(.not. due, 'kept within the lag')
  end do
  call reuse_due(r, .false., due)
  call check_true(due, 'rebuilt at the lag')
  call reuse_rebuilt(r)
  ! growth 0: any growth is ignored
  call reuse_watch(r, 2, 1.0e-3_rp, .true.)
  call reuse_watch(r, 50, 1.0e-3_rp, .true.)
  call reuse_due(r, .false., due)
  call check_true(.not. due, 'growth 0: off')
  call reuse_force(r)
  call reuse_due(r, .false., due)
  call check_true(due, 'forced')

  ! The safeguard, growth 1.5 and a long lag.
  call reuse_init(r, 1000, 1.5_rp)
  call reuse_due(r, .false., due)
  call reuse_rebuilt(r)
  call reuse_watch(r, 6, 1.0e-3_rp, .true.)      ! the reference: 2 a decade
  call reuse_watch(r, 8, 1.0e-3_rp, .true.)      ! 2.67 < 3
  call reuse_watch(r, 12, 1.0e-6_rp, .true.)     ! 2 a decade at another rtol
  call reuse_watch(r, 2, 1.0e-1_rp, .true.)      ! 1 decade: not counted (20 a decade otherwise)
  call reuse_watch(r, 40, 1.0e-3_rp, .false.)    ! converged by atol: no rate
  call reuse_due(r, .false., due)
  call check_true(.not. due, 'kept while the cycles a decade stay within 1.5x')
  call reuse_watch(r, 10, 1.0e-3_rp, .true.)     ! 3.33 > 3
  call reuse_due(r, .false., due)
  call check_true(due, 'rebuilt at the next assembly after a solve grew past 1.5x')
  call reuse_rebuilt(r)
  call check_true(reuse_grown(r) == 1, 'one rebuild asked for by the safeguard')
  ! after the rebuild the first counted solve is the new reference
  call reuse_watch(r, 10, 1.0e-3_rp, .true.)
  call reuse_watch(r, 14, 1.0e-3_rp, .true.)     ! 4.67 < 1.5 x 3.33
  call reuse_due(r, .false., due)
  call check_true(.not. due, 'a new reference after the rebuild')
  call check_true(reuse_grown(r) == 1, 'the lag''s rebuilds are not counted as grown')

  ! Pair blocks in S (self-contact): a lag of 20 shortened to PAIRS_PC_LAG,
  ! and back to 20 when they are gone.
  call reuse_init(r, 20, 0.0_rp)
  call reuse_due(r, .false., due)
  call reuse_rebuilt(r)
  do k = 1, PAIRS_PC_LAG - 1
    call reuse_due(r, .true., due)
    call check_true(.not. due, 'pairs: kept within PAIRS_PC_LAG')
  end do
  call reuse_due(r, .true., due)
  call check_true(due, 'pairs: rebuilt at PAIRS_PC_LAG')
  call reuse_rebuilt(r)
  do k = 1, 10
    call reuse_due(r, .false., due)
    call check_true(.not. due, 'no pairs: the lag of 20 again')
  end do

  call check_report()
end program test_pc_reuse
