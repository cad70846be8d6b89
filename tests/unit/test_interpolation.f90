! SPDX-License-Identifier: BSD-2-Clause
!> Unit test of the multigrid's cubic interpolation weights (module
!> interpolation): on every coarse size, every fine point reproduces a cubic
!> polynomial sampled on the coarse points exactly (to round-off), ends
!> included; the weights sum to one; below 4 coarse points lines are exact.
program test_interpolation
  use kinds, only: rp
  use interpolation, only: cubic_weights
  use check, only: check_true, check_close, check_report
  implicit none
  integer :: m, f, n, ix(4), worst_f, ms(5) = [2, 3, 5, 9, 17], im
  real(rp) :: w(4), err, worst, wsum
  character(len=64) :: label

  do im = 1, size(ms)
    m = ms(im)
    worst = 0.0_rp
    worst_f = -1
    wsum = 0.0_rp
    do f = 0, 2 * m - 2
      call cubic_weights(f, m, ix, w, n)
      call check_true(all(ix(1:n) >= 0 .and. ix(1:n) <= m - 1), 'coarse points inside the lattice')
      wsum = max(wsum, abs(sum(w(1:n)) - 1.0_rp))
      if (m >= 4) then
        err = abs(sum(w(1:n) * cubic(real(ix(1:n), rp))) - cubic(0.5_rp * f))
      else
        err = abs(sum(w(1:n) * line(real(ix(1:n), rp))) - line(0.5_rp * f))
      end if
      if (err > worst) then
        worst = err
        worst_f = f
      end if
    end do
    write(label, '(a, i0, a, i0)') 'exact on m = ', m, ', worst at fine point ', worst_f
    call check_close(worst, 0.0_rp, 0.0_rp, 1.0e-13_rp * (1.0_rp + real(m, rp)**3), trim(label))
    write(label, '(a, i0)') 'weights sum to 1 on m = ', m
    call check_close(wsum, 0.0_rp, 0.0_rp, 1.0e-15_rp, trim(label))
  end do
  call check_report()

contains

  elemental real(rp) function cubic(x)
    real(rp), intent(in) :: x
    cubic = 1.0_rp + 2.0_rp * x - 3.0_rp * x**2 + 0.5_rp * x**3
  end function cubic

  elemental real(rp) function line(x)
    real(rp), intent(in) :: x
    line = 1.0_rp - 0.7_rp * x
  end function line

end program test_interpolation
