! SPDX-License-Identifier: BSD-2-Clause
!> Unit tests of self-contact's step guarantee (module self_step) on a
!> rolled sheet (turns 4 mm apart, contact distance xi = 1 mm) and random
!> updates that would cross the turns (random per node, smooth, and one node
!> pushed through the next turn), against the brute force: the path of the
!> limited update, sampled at 200 points, keeps every gap of every pair
!> (every point against every triangle, every edge against every edge that
!> share no node) positive, for
!>   (a) the global ACCD alpha over the swept candidates, and
!>   (b) OGC's per-vertex bounds with the clamp, where moreover each pair
!>       keeps at least (1 - 2 gamma) of its starting gap.
!> Then the comparison the issue asks for, printed: on a larger rolled
!> sheet and a folded one, over random updates of several kinds and sizes,
!> how many nodes each flavour stalls ((a): every moving node once alpha <
!> 1; (b): the nodes clamped), how often (b) stalls fewer than (a), and the
!> share of the update each keeps.
program test_self_step
  use, intrinsic :: iso_fortran_env, only: output_unit
  use kinds, only: rp
  use contact_ccd, only: ACCD_S
  use contact_faces, only: SPLIT_MAIN, SPLIT_ANTI
  use self_broad, only: self_lattice_t, self_pairs_t, self_candidates, self_candidates_swept, self_row_slots, OWN_LOWEST, &
                        self_pair_positions, self_pair_distance2
  use self_step, only: self_alpha_ccd, self_vertex_dmin, self_vertex_bounds, self_clamp, OGC_GAMMA
  use self_shapes, only: roll_shape, fold_shape, all_pairs
  use check, only: check_true, check_report, seed_random
  implicit none
  real(rp), parameter :: XI = 0.001_rp, DHAT = 0.002_rp
  integer :: kind

  call seed_random(4903)
  do kind = 1, 3
    call guarantee(kind, SPLIT_MAIN)
    call guarantee(kind, SPLIT_ANTI)
  end do
  call compare('rolled 16 x 48, turns 4 mm apart', 1)
  call compare('folded 16 x 48, layers 3.5 mm apart', 2)
  call check_report()

contains

  !> A random update of the given kind: 1 random per node (up to 3 mm), 2 smooth (up to 4 mm),
  !> 3 small smooth motion (0.5 mm) with one node pushed 6 mm towards the roll's axis.
  subroutine random_update(lat, x, kind, scale, dx)
    type(self_lattice_t), intent(in) :: lat
    real(rp), intent(in) :: x(:, 0:, 0:)
    integer, intent(in) :: kind
    real(rp), intent(in) :: scale
    real(rp), intent(out) :: dx(:, 0:, 0:)
    real(rp) :: u(3, 3), ph(3), r(3)
    integer :: i, j, i0, j0

    select case (kind)
    case (1)
      call random_number(dx)
      dx = 0.003_rp * scale * (2.0_rp * dx - 1.0_rp)
    case default
      call random_number(u)
      call random_number(ph)
      do j = 0, lat%ny - 1
        do i = 0, lat%nx - 1
          dx(:, i, j) = merge(0.004_rp, 0.0005_rp, kind == 2) * scale * (2.0_rp * u(:, 1) - 1.0_rp) &
                        * sin(6.0_rp * ph + u(:, 2) * i * 0.7_rp + u(:, 3) * j * 0.5_rp)
        end do
      end do
      if (kind == 3) then
        call random_number(r)
        i0 = int(r(1) * lat%nx)
        j0 = lat%ny / 4 + int(r(2) * lat%ny / 2)
        r = -[0.0_rp, x(2, i0, j0), x(3, i0, j0)]
        dx(:, i0, j0) = dx(:, i0, j0) + 0.006_rp * scale * r / norm2(r)
      end if
    end select
  end subroutine random_update

  !> Smallest gap over every pair at x + t dx, t = 0, 1/200, ..., 1; with gap0 given, also
  !> the smallest gap(t) - keep gap0 of any pair.
  subroutine path_gaps(lat, rows, allp, x, dx, keep, gmin, margin)
    type(self_lattice_t), intent(in) :: lat
    integer, intent(in) :: rows(:)
    type(self_pairs_t), intent(in) :: allp
    real(rp), intent(in) :: x(:, 0:, :), dx(:, 0:, :), keep
    real(rp), intent(out) :: gmin, margin
    integer, allocatable :: slot(:)
    real(rp), allocatable :: gap0(:)
    real(rp) :: g, y(3, 4), d(3, 4)
    integer :: m, it

    allocate(slot(0:lat%ny - 1), gap0(allp%n))
    call self_row_slots(lat, rows, slot)
    gmin = huge(1.0_rp)
    margin = huge(1.0_rp)
    do m = 1, allp%n
      y = self_pair_positions(lat, slot, x, allp%node(:, m))
      d = self_pair_positions(lat, slot, dx, allp%node(:, m))
      gap0(m) = sqrt(self_pair_distance2(allp%kind(m), y)) - XI
      ! a pair that its path cannot bring below keep gap0 is skipped: the distance moves
      ! at most max |d_k| + max |d_l| (each side's largest displacement)
      if ((1.0_rp - keep) * gap0(m) > 2.001_rp * maxval(norm2(d, dim=1)) + 1.0e-9_rp) cycle
      do it = 0, 200
        g = sqrt(self_pair_distance2(allp%kind(m), y + (it / 200.0_rp) * d)) - XI
        gmin = min(gmin, g)
        margin = min(margin, g - keep * gap0(m))
      end do
    end do
  end subroutine path_gaps

  !> Both flavours on one random update of a rolled 8 x 24 sheet, against the brute force.
  subroutine guarantee(kind, split)
    integer, intent(in) :: kind, split
    type(self_lattice_t) :: lat
    type(self_pairs_t) :: allp, pairs
    real(rp), allocatable :: x(:, :, :), dx(:, :, :), dxc(:, :, :), dmin(:, :), b(:, :)
    integer, allocatable :: rows(:)
    real(rp) :: alpha, g0, gmin, margin, gfree, mfree, r
    integer :: j, ncl
    character(len=48) :: what

    write(what, '(a,i0,a,i0)') 'update kind ', kind, ', split ', split
    lat = self_lattice_t(nx=8, ny=24, split=split, ax=0.01_rp, ay=0.01_rp)
    allocate(x(3, 0:lat%nx - 1, 0:lat%ny - 1), dx(3, 0:lat%nx - 1, 0:lat%ny - 1))
    call roll_shape(lat, 0.012_rp, 0.004_rp, 0.0005_rp, x)
    rows = [(j, j = 0, lat%ny - 1)]
    call all_pairs(lat, rows, allp)
    dx = 0.0_rp
    call path_gaps(lat, rows, allp, x, dx, 0.0_rp, g0, margin)
    call check_true(g0 > 0.0_rp, trim(what)//': the start is apart')
    ! an update that crosses the turns when taken whole (a few draws at most)
    do j = 1, 20
      call random_update(lat, x, kind, 1.5_rp, dx)
      call path_gaps(lat, rows, allp, x, dx, 0.0_rp, gfree, mfree)
      if (gfree < 0.0_rp) exit
    end do
    call check_true(gfree < 0.0_rp, trim(what)//': the update unlimited crosses')

    ! (a) global alpha
    call self_candidates_swept(lat, rows, x, dx, 0, lat%ny - 1, OWN_LOWEST, XI, DHAT + XI, pairs)
    alpha = self_alpha_ccd(lat, rows, x, dx, pairs, XI, ACCD_S)
    call path_gaps(lat, rows, allp, x, alpha * dx, 0.0_rp, gmin, margin)
    call check_true(alpha > 0.0_rp .and. alpha < 1.0_rp, trim(what)//': (a) 0 < alpha < 1')
    call check_true(gmin > 0.0_rp, trim(what)//': (a) the path to alpha dx keeps every gap > 0')

    ! (b) per-vertex bounds, search radius r
    r = 2.0_rp * (DHAT + XI)
    call self_candidates(lat, rows, x, 0, lat%ny - 1, OWN_LOWEST, r, DHAT + XI, pairs)
    allocate(dmin(0:lat%nx - 1, size(rows)), b(0:lat%nx - 1, size(rows)))
    dmin = r
    call self_vertex_dmin(lat, rows, x, pairs, dmin)
    call self_vertex_bounds(dmin, XI, OGC_GAMMA, b)
    dxc = dx
    call self_clamp(dxc, b, ncl)
    call path_gaps(lat, rows, allp, x, dxc, 1.0_rp - 2.0_rp * OGC_GAMMA, gmin, margin)
    call check_true(ncl > 0, trim(what)//': (b) some nodes clamped')
    call check_true(gmin > 0.0_rp, trim(what)//': (b) the clamped path keeps every gap > 0')
    call check_true(margin > -1.0e-12_rp, trim(what)//': (b) each pair keeps (1 - 2 gamma) of its gap')
    call check_true(all(norm2(dxc, dim=1) <= b * (1.0_rp + 1.0e-12_rp)), trim(what)//': (b) |dx_v| <= b_v')
  end subroutine guarantee

  !> The two flavours' stalls over many random updates (printed; docs/self-contact.md).
  subroutine compare(title, shape)
    character(*), intent(in) :: title
    integer, intent(in) :: shape
    type(self_lattice_t) :: lat
    type(self_pairs_t) :: pairs
    real(rp), allocatable :: x(:, :, :), dx(:, :, :), dxc(:, :, :), dmin(:, :), b(:, :)
    integer, allocatable :: rows(:)
    real(rp) :: alpha, r, scale, keep_a(2), keep_b(2, 2), u
    integer :: j, trial, kind, ncl, nmove, ir, fewer(2), more(2), stall_a, stall_b(2), ntrial, ntot
    integer :: tot_trials, tot_fewer(2), tot_more(2)
    real(rp), parameter :: SCALES(4) = [0.1_rp, 0.3_rp, 1.0_rp, 2.0_rp]
    character(len=13), parameter :: LABEL(3) = ['per node     ', 'smooth       ', 'small + push ']

    lat = self_lattice_t(nx=16, ny=48, split=SPLIT_MAIN, ax=0.01_rp, ay=0.01_rp)
    allocate(x(3, 0:lat%nx - 1, 0:lat%ny - 1), dx(3, 0:lat%nx - 1, 0:lat%ny - 1))
    if (shape == 1) then
      call roll_shape(lat, 0.012_rp, 0.004_rp, 0.0005_rp, x)
    else
      call fold_shape(lat, 24, 0.0025_rp + XI, x)
    end if
    rows = [(j, j = 0, lat%ny - 1)]
    allocate(dmin(0:lat%nx - 1, size(rows)), b(0:lat%nx - 1, size(rows)))
    ntot = lat%nx * lat%ny
    write(output_unit, '(a)') 'step limit, '//title//':'
    write(output_unit, '(a)') '  update, size: % of nodes stalled by (a), (b) r = 3 mm, (b) r = 6 mm; ' // &
      'trials where (b) stalls fewer / more than (a) (r = 3 mm, 6 mm); share of the update kept (a), (b)'
    tot_trials = 0
    tot_fewer = 0
    tot_more = 0
    do kind = 1, 3
      do j = 1, size(SCALES)
        scale = SCALES(j)
        ntrial = 10
        stall_a = 0
        stall_b = 0
        fewer = 0
        more = 0
        keep_a = 0.0_rp
        keep_b = 0.0_rp
        do trial = 1, ntrial
          call random_update(lat, x, kind, scale, dx)
          if (shape == 2 .and. kind == 3) then
            ! on the fold, push down the upper layer's node instead of towards an axis
            call random_number(u)
            dx(3, int(u * lat%nx), 36) = dx(3, int(u * lat%nx), 36) - 0.006_rp * scale
          end if
          nmove = count(norm2(dx, dim=1) > 0.0_rp)
          call self_candidates_swept(lat, rows, x, dx, 0, lat%ny - 1, OWN_LOWEST, XI, DHAT + XI, pairs)
          alpha = self_alpha_ccd(lat, rows, x, dx, pairs, XI, ACCD_S)
          if (alpha < 1.0_rp) stall_a = stall_a + nmove
          keep_a(1) = keep_a(1) + alpha
          do ir = 1, 2
            r = ir * (DHAT + XI)
            call self_candidates(lat, rows, x, 0, lat%ny - 1, OWN_LOWEST, r, DHAT + XI, pairs)
            dmin = r
            call self_vertex_dmin(lat, rows, x, pairs, dmin)
            call self_vertex_bounds(dmin, XI, OGC_GAMMA, b)
            dxc = dx
            call self_clamp(dxc, b, ncl)
            stall_b(ir) = stall_b(ir) + ncl
            if (ncl < merge(nmove, 0, alpha < 1.0_rp)) fewer(ir) = fewer(ir) + 1
            if (ncl > merge(nmove, 0, alpha < 1.0_rp)) more(ir) = more(ir) + 1
            keep_b(ir, 1) = keep_b(ir, 1) + sum(norm2(dxc, dim=1)) / sum(norm2(dx, dim=1))
          end do
        end do
        write(output_unit, '(2x,a,f4.1,a,3f6.1,a,i2,a,i2,a,i2,a,i2,a,i0,a,3f6.2)') &
          LABEL(kind), scale, ': stalled %', 100.0_rp * stall_a / (ntrial * ntot), &
          100.0_rp * stall_b / (ntrial * ntot), '; fewer ', fewer(1), ',', fewer(2), ' more ', more(1), ',', more(2), &
          ' of ', ntrial, '; kept', keep_a(1) / ntrial, keep_b(:, 1) / ntrial
        tot_trials = tot_trials + ntrial
        tot_fewer = tot_fewer + fewer
        tot_more = tot_more + more
      end do
    end do
    write(output_unit, '(a,i0,a,i0,a,i0,a,i0,a,i0,a)') '  in all: (b) stalls fewer nodes than (a) in ', tot_fewer(1), &
      ' (r = 3 mm) and ', tot_fewer(2), ' (r = 6 mm) of ', tot_trials, ' updates, more in ', tot_more(1), ' and ', &
      tot_more(2), ', as many in the others'
  end subroutine compare

end program test_self_step
