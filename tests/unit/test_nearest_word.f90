! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of module nearest_word: the distance of slips (a swap of two
!> neighbours is one), and the hint for an option nothing reads: the
!> nearest known option, or the one a word cut short begins, or none.
program test_nearest_word
  use nearest_word, only: edit_distance, nearest
  use check, only: check_true, check_report
  implicit none
  character(24), parameter :: known(9) = [character(24) :: '-ts_type', '-ts_adapt_type', '-ts_max_steps', &
    '-snes_monitor', '-ksp_monitor', '-snes_rtol', '-nuno_mg_levels', '-nuno_mg_sweeps', '-ts_rtol']

  call check_true(edit_distance('', '') == 0, 'empty words')
  call check_true(edit_distance('abc', '') == 3, 'deletions')
  call check_true(edit_distance('-ts_tpye', '-ts_type') == 1, 'a swap of neighbours is one')
  call check_true(edit_distance('kitten', 'sitting') == 3, 'kitten/sitting')
  call check_true(edit_distance('-ts_type', '-ts_type') == 0, 'the same word')
  call check_true(edit_distance('ca', 'abc') == 3, 'optimal string alignment (not Damerau): ca/abc is 3')

  call check_true(nearest('-ts_tpye', known) == '-ts_type', '-ts_tpye: -ts_type')
  call check_true(nearest('-ts_max_step', known) == '-ts_max_steps', '-ts_max_step: -ts_max_steps')
  call check_true(nearest('-snes_monitr', known) == '-snes_monitor', '-snes_monitr: -snes_monitor')
  call check_true(nearest('-ts_adapt', known) == '-ts_adapt_type', 'cut short: -ts_adapt_type')
  call check_true(nearest('-nuno_mg_level', known) == '-nuno_mg_levels', 'the nearer of two')
  call check_true(nearest('-foo_bar', known) == '', 'nothing near: no hint')
  call check_true(nearest('-ts_type', known) == '', 'a known word itself is no hint')
  call check_report()
end program test_nearest_word
