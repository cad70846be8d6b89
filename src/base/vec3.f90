! SPDX-License-Identifier: BSD-2-Clause
!> Small 3-vector helpers shared by the scene set-up and the diagnostics.
module vec3
  use kinds, only: rp
  implicit none
  private
  public :: cross
contains
  !> a x b
  pure function cross(a, b) result(c)
    real(rp), intent(in) :: a(3), b(3)
    real(rp) :: c(3)
    c = [a(2) * b(3) - a(3) * b(2), a(3) * b(1) - a(1) * b(3), a(1) * b(2) - a(2) * b(1)]
  end function cross
end module vec3
