! SPDX-License-Identifier: BSD-2-Clause
!> The K-cycle of nuno's multigrid (Notay and Vassilevski, Numer. Linear
!> Algebra Appl. 15 (2008) 473-487): where a cycle would visit a coarse
!> level once (V-cycle, kaskade) or twice (W-cycle), it solves that level
!> by at most two iterations of flexible CG, each preconditioned by the
!> level's own cycle, the second only where the first leaves more than kt
!> of the level's right-hand side. The iterations' step lengths undo what
!> a single visit gets wrong at the rediscretised levels' corners and pins
!> (their correction overshoots up to 4.5x there: docs/performance.md, "The
!> multigrid with bending"); the second visit is paid only where needed.
!> A submodule of stencil_mg: it works on the hierarchy's level records;
!> the level's cycle comes as an argument.
submodule (stencil_mg) stencil_mg_krylov
  implicit none

contains

  !> Level l's x from its rhs (l a coarse level, not the coarsest): c =
  !> B b, alpha = (c, b) / (c, A c), r1 = b - alpha A c; if ||r1|| > kt
  !> ||b||, d = B r1 and x the A-orthogonal combination of c and d that
  !> minimises the energy of the error, else x = alpha c. B: the level's
  !> cycle (V-cycle or kaskade from level l). The sums in double precision,
  !> over the ranks where the level is distributed. Collective.
  module recursive subroutine krylov_level(mg, l, cycle_and_residual)
    type(stencil_mg_t), intent(inout) :: mg
    integer, intent(in) :: l
    procedure(level_step) :: cycle_and_residual
    real(rp) :: s(3), t(3), alpha, rho1, rho2, gam, beta, a2, fc, fd
    integer :: i, j, c, k
    associate (lv => mg%lev(l), ys => mg%lev(l)%a%ys, ye => mg%lev(l)%a%ye, nx => mg%lev(l)%a%nx)
      lv%kw(:, :, :, 1) = lv%rhs
      call cycle_and_residual(mg, l)
      ! c, and A c = b - (b - A c); sums (c, A c), (c, b), (b, b)
      s = 0.0_rp
      do j = ys, ye
        do c = 1, 3
          do i = 0, nx - 1
            lv%kw(i, c, j, 2) = lv%x(i, c, j)
            lv%kw(i, c, j, 3) = lv%kw(i, c, j, 1) - lv%res(i, c, j)
            s(1) = s(1) + real(lv%x(i, c, j), rp) * real(lv%kw(i, c, j, 3), rp)
            s(2) = s(2) + real(lv%x(i, c, j), rp) * real(lv%kw(i, c, j, 1), rp)
            s(3) = s(3) + real(lv%kw(i, c, j, 1), rp)**2
          end do
        end do
      end do
      call level_sum(s)
      if (s(1) <= 0.0_rp) return   ! no energy (b = 0, or B not positive there): x = c
      rho1 = s(1)
      alpha = s(2) / rho1
      ! r1 = b - alpha A c, the next rhs (zero at the constrained nodes, as restrict_level's)
      lv%rhs = lv%kw(:, :, :, 1) - real(alpha, mp) * lv%kw(:, :, :, 3)
      call zero_fixed()
      t(1) = sum(real(lv%rhs, rp)**2)
      call level_sum(t(1:1))
      if (t(1) <= mg%kt**2 * s(3)) then
        lv%x(0:nx - 1, :, ys:ye) = real(alpha, mp) * lv%kw(:, :, :, 2)
        return
      end if
      call cycle_and_residual(mg, l)
      ! d and A d = r1 - (r1 - A d); sums (d, A c), (d, A d), (d, r1)
      t = 0.0_rp
      do j = ys, ye
        do c = 1, 3
          do i = 0, nx - 1
            t(1) = t(1) + real(lv%x(i, c, j), rp) * real(lv%kw(i, c, j, 3), rp)
            t(2) = t(2) + real(lv%x(i, c, j), rp) * real(lv%rhs(i, c, j) - lv%res(i, c, j), rp)
            t(3) = t(3) + real(lv%x(i, c, j), rp) * real(lv%rhs(i, c, j), rp)
          end do
        end do
      end do
      call level_sum(t)
      gam = t(1)
      beta = t(2)
      a2 = t(3)
      rho2 = beta - gam * gam / rho1
      if (rho2 <= 1.0e-12_rp * beta) then   ! d adds nothing A-independent of c
        lv%x(0:nx - 1, :, ys:ye) = real(alpha, mp) * lv%kw(:, :, :, 2)
        return
      end if
      fc = alpha - gam * a2 / (rho1 * rho2)
      fd = a2 / rho2
      do k = ys, ye
        lv%x(0:nx - 1, :, k) = real(fc, mp) * lv%kw(:, :, k, 2) + real(fd, mp) * lv%x(0:nx - 1, :, k)
      end do
    end associate
  contains
    !> Sums over the ranks where level l is distributed.
    subroutine level_sum(v)
      real(rp), intent(inout) :: v(:)
      integer :: ierr
      if (.not. mg%lev(l)%replicated) call MPI_Allreduce(MPI_IN_PLACE, v, size(v), MPI_DOUBLE_PRECISION, MPI_SUM, mg%comm, ierr)
    end subroutine level_sum
    !> The rhs zero at the level's constrained nodes.
    subroutine zero_fixed()
      integer :: n
      if (.not. allocated(mg%lev(l)%fixed)) return
      do n = 1, size(mg%lev(l)%fixed, 2)
        mg%lev(l)%rhs(mg%lev(l)%fixed(1, n), :, mg%lev(l)%fixed(2, n)) = 0.0_mp
      end do
    end subroutine zero_fixed
  end subroutine krylov_level

end submodule stencil_mg_krylov
