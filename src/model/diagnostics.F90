! SPDX-License-Identifier: BSD-2-Clause
!> Diagnostics of one output time (docs/model.md section 8) that follow from the
!> state alone: energies, momenta, centre-line length and flatness. Local sums
!> over owned nodes and anchor-owned elements, then one sum-reduction and one
!> max-reduction, so every rank gets the same values.
module diagnostics
  use mpi
  use kinds, only: rp
  use lattice, only: lattice_t
  use vec3, only: cross
  use forces, only: element_energies
  implicit none
  private
  public :: state_diagnostics_t, state_diagnostics

  type :: state_diagnostics_t
    real(rp) :: kinetic = 0, stretch = 0, bend = 0
    real(rp) :: momentum(3) = 0, angular_momentum(3) = 0
    real(rp) :: length = 0, flatness = 0
    real(rp) :: mgx = 0       !< sum m g . x, for the work of gravity
  end type state_diagnostics_t

  integer, parameter :: nsum = 23

contains

  !> Diagnostics of the state u(0:5, 0:nx-1, gys:gye) (ghost rows filled).
  subroutine state_diagnostics(lat, u, gravity, comm, d, ierr)
    type(lattice_t), intent(in) :: lat
    real(rp), intent(in) :: u(0:5, 0:lat%nx - 1, lat%gys:lat%gye)
    real(rp), intent(in) :: gravity(3)
    integer, intent(in) :: comm
    type(state_diagnostics_t), intent(out) :: d
    integer, intent(out) :: ierr
    real(rp) :: s(nsum), g(nsum), m, x(3), v(3), c(3), cov(3, 3), w(3), work(64), dist, dmax, xref(3)
    integer :: i, j, jc, info, nn

    s = 0.0_rp
    ! Centre of the rest lattice: a shift that keeps the covariance sums well conditioned.
    xref = [0.5_rp * (lat%nx - 1) * lat%ax, 0.5_rp * (lat%ny - 1) * lat%ay, 0.0_rp]
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        m = lat%mass(i, j)
        x = u(0:2, i, j)
        v = u(3:5, i, j)
        s(1) = s(1) + 0.5_rp * m * dot_product(v, v)
        s(4:6) = s(4:6) + m * v
        s(7:9) = s(7:9) + m * cross(x, v)
        s(10) = s(10) + m * dot_product(gravity, x)
        x = x - xref
        s(12:14) = s(12:14) + x
        s(15:17) = s(15:17) + x * x
        s(18:20) = s(18:20) + [x(1) * x(2), x(1) * x(3), x(2) * x(3)]
      end do
    end do
    call element_energies(lat, u, s(2), s(3))
    jc = (lat%ny - 1) / 2
    if (jc >= lat%ys .and. jc <= lat%ye) then
      do i = 0, lat%nx - 2
        s(11) = s(11) + norm2(u(0:2, i + 1, jc) - u(0:2, i, jc))
      end do
    end if
    call MPI_Allreduce(s, g, nsum, MPI_DOUBLE_PRECISION, MPI_SUM, comm, ierr)
    if (ierr /= MPI_SUCCESS) return

    d%kinetic = g(1)
    d%stretch = g(2)
    d%bend = g(3)
    d%momentum = g(4:6)
    d%angular_momentum = g(7:9)
    d%mgx = g(10)
    d%length = g(11)

    ! Flatness: largest distance from the orthogonal least-squares plane
    ! (normal = eigenvector of the smallest eigenvalue of the covariance).
    nn = lat%nx * lat%ny
    c = g(12:14) / nn
    cov(1, 1) = g(15) / nn - c(1)**2
    cov(2, 2) = g(16) / nn - c(2)**2
    cov(3, 3) = g(17) / nn - c(3)**2
    cov(1, 2) = g(18) / nn - c(1) * c(2)
    cov(1, 3) = g(19) / nn - c(1) * c(3)
    cov(2, 3) = g(20) / nn - c(2) * c(3)
    cov(2, 1) = cov(1, 2)
    cov(3, 1) = cov(1, 3)
    cov(3, 2) = cov(2, 3)
    call dsyev('V', 'U', 3, cov, 3, w, work, size(work), info)
    dmax = 0.0_rp
    do j = lat%ys, lat%ye
      do i = 0, lat%nx - 1
        dist = abs(dot_product(u(0:2, i, j) - xref - c, cov(:, 1)))
        dmax = max(dmax, dist)
      end do
    end do
    call MPI_Allreduce(dmax, d%flatness, 1, MPI_DOUBLE_PRECISION, MPI_MAX, comm, ierr)
  end subroutine state_diagnostics



end module diagnostics
