! SPDX-License-Identifier: BSD-2-Clause
!> The error that ends a run collectively, kept for the run driver, which
!> ends the run as failed with it (status 'failed: ...'): an output or
!> checkpoint write that failed on some rank (agreed by every rank), a
!> wall-clock checkpoint that could not be written, the monitor's stall
!> check. This module is the record's only writer; the line on stderr is
!> its callers' (each says it where it knows the rank).
module run_error
  implicit none
  private
  public :: run_error_t, run_error_set, run_error_first, run_error_any, run_error_text

  !> The one error of a run; '' while there is none.
  type :: run_error_t
    private
    character(len=512) :: text = ''
  end type run_error_t

contains

  !> The run's error is msg (a later one replaces an earlier one: the last
  !> write that failed is the one the file's status names).
  subroutine run_error_set(e, msg)
    type(run_error_t), intent(inout) :: e
    character(len=*), intent(in) :: msg
    e%text = msg
  end subroutine run_error_set

  !> The run's error is msg unless there is one already, which stands;
  !> taken: msg was kept.
  subroutine run_error_first(e, msg, taken)
    type(run_error_t), intent(inout) :: e
    character(len=*), intent(in) :: msg
    logical, intent(out) :: taken
    taken = len_trim(e%text) == 0
    if (taken) e%text = msg
  end subroutine run_error_first

  !> There is an error.
  pure logical function run_error_any(e)
    type(run_error_t), intent(in) :: e
    run_error_any = len_trim(e%text) > 0
  end function run_error_any

  !> The error's text, trimmed ('' if none).
  pure function run_error_text(e) result(s)
    type(run_error_t), intent(in) :: e
    character(len=:), allocatable :: s
    s = trim(e%text)
  end function run_error_text

end module run_error
