! SPDX-License-Identifier: BSD-2-Clause
!> Energy-based bending on one triple (p, q, r) centred on q, packed as
!> x9 = [x_p; x_q; x_r] (docs/model.md section 3 'energy'). With the edges
!> e1 = x_q - x_p, e2 = x_r - x_q the curvature binormal is
!>   kb = 2 (e1 x e2)/psi,  psi = |e1||e2| + e1.e2,  |kb| = 2 tan(theta/2),
!> the energy W = 1/2 k_b |kb|^2 and the Rayleigh function R = 1/2 eta_b |J v|^2,
!> J = d kb/d x9 (3x9). Forces f9 = -k_b J^T kb - eta_b J^T J v9.
!> Everything is first computed in the 6 edge variables (e1, e2): kb depends
!> on x9 only through them, e = T x9 with the constant T = [[-I, I, 0], [0, -I, I]],
!> so J = Je T and every 9x9 matrix is T^T (6x6) T. The second derivatives of
!> kb are written analytically (kb_c = 2 z_c/psi with z = e1 x e2 bilinear):
!> for s = lambda.kb with fixed lambda,
!>   Hess s = [2 Hess(lambda.z) - grad s grad psi^T - grad psi grad s^T - s Hess psi]/psi.
module bending_energy
  use kinds, only: rp
  implicit none
  private
  public :: energy_force, energy_force_lanes, energy_jacobian, energy_jacobian_edges, energy_jacobian_lanes, energy_bend_energy, energy_power, energy_power_lanes

  ! 1 + cos(theta) = psi/(|e1||e2|) below this: kb blows up (folded-back triple).
  real(rp), parameter :: FOLD_TOL = 1.0e-12_rp
  ! An edge shorter than this fraction of the other (or than EDGE_ABS) counts as zero.
  real(rp), parameter :: EDGE_REL = 1.0e-12_rp
  real(rp), parameter :: EDGE_ABS = 1.0e-150_rp

contains

  !> Forces on p, q, r; the damping part is skipped when eta_b == 0. ok = .false. (f9 = 0) when degenerate.
  pure subroutine energy_force(k_b, eta_b, x9, v9, f9, ok)
    real(rp), intent(in) :: k_b           ! bending stiffness [energy]
    real(rp), intent(in) :: eta_b         ! bending damping [energy*time]
    real(rp), intent(in) :: x9(9)         ! [x_p; x_q; x_r] [length]
    real(rp), intent(in) :: v9(9)         ! [v_p; v_q; v_r] [length/time]
    real(rp), intent(out) :: f9(9)        ! [force]
    logical, intent(out) :: ok
    real(rp) :: e1(3), e2(3), l1, l2, psi, kb(3), gpsi(6), je(3,6), lam(3), ge(6), dl(6), kbdot(3)

    f9 = 0.0_rp
    call edge_state(x9, e1, e2, l1, l2, psi, kb, gpsi, je, ok)
    if (.not. ok) return
    lam = k_b*kb
    if (eta_b /= 0.0_rp) then           ! exact zero test: skip the damping work when off
      call edge_rate(v9, dl)
      kbdot = matmul(je, dl)
      lam = lam + eta_b*kbdot
    end if
    ge = matmul(lam, je)                 ! Je^T lambda = -(force) in edge variables
    call edge_to_nodes_vec(ge, f9)
    f9 = -f9
  end subroutine energy_force

  !> energy_force for n triples at once (the same k_b and eta_b), from
  !> their edges and edge rates as energy_jacobian_lanes takes them:
  !> f(i, 1:9) = [f_p; f_q; f_r] of lane i, ok(i), as energy_force gives
  !> them up to round-off (degenerate lanes: f = 0, ok false). Vectorised
  !> over the lanes as energy_jacobian_lanes.
  pure subroutine energy_force_lanes(n, ld, k_b, eta_b, e1, e2, de, f, ok)
    integer, intent(in) :: n              ! lanes 1..n of arrays of leading dimension ld >= n
    integer, intent(in) :: ld
    real(rp), intent(in) :: k_b, eta_b    ! [energy], [energy*time]
    real(rp), intent(in) :: e1(ld, 3), e2(ld, 3)  ! [length]
    real(rp), intent(in) :: de(ld, 6)     ! [length/time]
    real(rp), intent(inout) :: f(ld, 9)   ! [force] (lanes 1..n set)
    logical, intent(inout) :: ok(ld)
    real(rp) :: a(3), b(3), dl(6), l1, l2, ipsi, il1, il2, kb(3), gpsi(6), je(3, 6), lam(3), ge(6), keep
    real(rp) :: psi, z(3)                 ! (work of lane_geometry.inc)
    integer :: i, q, c

    !GCC$ ivdep
    do i = 1, n
      include 'lane_geometry.inc'
      !GCC$ unroll 3
      do c = 1, 3
        lam(c) = k_b*kb(c) + eta_b*(je(c, 1)*dl(1) + je(c, 2)*dl(2) + je(c, 3)*dl(3) &
                                    + je(c, 4)*dl(4) + je(c, 5)*dl(5) + je(c, 6)*dl(6))
      end do
      !GCC$ unroll 6
      do q = 1, 6
        ge(q) = keep*(lam(1)*je(1, q) + lam(2)*je(2, q) + lam(3)*je(3, q))
      end do
      ! f9 = -T^T ge
      !GCC$ unroll 3
      do c = 1, 3
        f(i, c) = ge(c)
        f(i, 3 + c) = ge(3 + c) - ge(c)
        f(i, 6 + c) = -ge(3 + c)
      end do
    end do
  end subroutine energy_force_lanes

  !> K9 = df9/dx9 (exact, or -k_b J^T J with gauss_newton) and C9 = df9/dv9 = -eta_b J^T J.
  pure subroutine energy_jacobian(k_b, eta_b, x9, v9, gauss_newton, K9, C9, ok)
    real(rp), intent(in) :: k_b, eta_b    ! [energy], [energy*time]
    real(rp), intent(in) :: x9(9), v9(9)  ! [length], [length/time]
    logical, intent(in) :: gauss_newton   ! .true.: symmetric negative semidefinite part only
    real(rp), intent(out) :: K9(9,9)      ! [force/length]
    real(rp), intent(out) :: C9(9,9)      ! [force*time/length]
    logical, intent(out) :: ok
    real(rp) :: ke(6,6), ce(6,6)

    K9 = 0.0_rp
    C9 = 0.0_rp
    call energy_jacobian_edges(k_b, eta_b, x9, v9, gauss_newton, ke, ce, ok)
    if (.not. ok) return
    call edge_to_nodes_mat(ke, K9)
    if (eta_b /= 0.0_rp) call edge_to_nodes_mat(ce, C9)
  end subroutine energy_jacobian

  !> The Jacobians in the edge variables e = (x_q - x_p, x_r - x_q):
  !> K9 = T^T ke T, C9 = T^T ce T (ce = 0 when eta_b == 0), for callers that
  !> combine them before going to the nodes (module reduced_assembly).
  pure subroutine energy_jacobian_edges(k_b, eta_b, x9, v9, gauss_newton, ke, ce, ok)
    real(rp), intent(in) :: k_b, eta_b    ! [energy], [energy*time]
    real(rp), intent(in) :: x9(9), v9(9)  ! [length], [length/time]
    logical, intent(in) :: gauss_newton   ! .true.: symmetric negative semidefinite part only
    real(rp), intent(out) :: ke(6,6)      ! [force/length]
    real(rp), intent(out) :: ce(6,6)      ! [force*time/length]
    logical, intent(out) :: ok
    real(rp) :: e1(3), e2(3), l1, l2, psi, kb(3), gpsi(6), je(3,6)
    real(rp) :: jtj(6,6), hs(6,6), ae(3,6), dl(6), kbdot(3), lam(3), gs(6), s
    real(rp) :: e1h(3), e2h(3), hpd(6), dpsi, sk(3,3), ipsi
    logical :: damped
    integer :: i, j

    ke = 0.0_rp
    ce = 0.0_rp
    call edge_state(x9, e1, e2, l1, l2, psi, kb, gpsi, je, ok)
    if (.not. ok) return
    jtj = matmul(transpose(je), je)
    damped = eta_b /= 0.0_rp            ! exact zero test: skip the damping work when off
    if (damped) ce = -eta_b*jtj
    ke = -k_b*jtj
    if (.not. gauss_newton) then
      ipsi = 1.0_rp/psi
      e1h = e1*(1.0_rp/l1)
      e2h = e2*(1.0_rp/l2)
      lam = k_b*kb
      if (damped) then
        call edge_rate(v9, dl)
        kbdot = matmul(je, dl)
        lam = lam + eta_b*kbdot
        ! A_e = d Je[dl], row c = (Hess kb_c dl)^T, from the formula in the
        ! module header with lambda = unit vector c, applied to dl.
        call hess_psi_times(e1h, e2h, l1, l2, dl, hpd)
        dpsi = dot_product(gpsi, dl)
        ae(:,1:3) = -2.0_rp*skew(dl(4:6))
        ae(:,4:6) = 2.0_rp*skew(dl(1:3))
        do j = 1, 6
          do i = 1, 3
            ae(i,j) = (ae(i,j) - dpsi*je(i,j) - kbdot(i)*gpsi(j) - kb(i)*hpd(j))*ipsi
          end do
        end do
        do j = 1, 6
          do i = 1, 6
            ke(i,j) = ke(i,j) - eta_b*dot_product(je(:,i), ae(:,j))   ! - eta_b Je^T A_e
          end do
        end do
      end if
      ! Weighted Hessian sum_c lambda_c Hess kb_c, lambda = k_b kb + eta_b kbdot.
      s = dot_product(lam, kb)
      gs = matmul(lam, je)
      call hess_psi(e1h, e2h, l1, l2, hs)
      sk = skew(lam)
      do j = 1, 6
        do i = 1, 6
          hs(i,j) = -s*hs(i,j) - gs(i)*gpsi(j) - gpsi(i)*gs(j)
        end do
      end do
      ! Hess(lambda.z): z = e1 x e2, lambda.z = e1.(e2 x lambda); blocks (1,2) = -[lambda]x, (2,1) = [lambda]x.
      hs(1:3,4:6) = hs(1:3,4:6) - 2.0_rp*sk
      hs(4:6,1:3) = hs(4:6,1:3) + 2.0_rp*sk
      ke = ke - hs*ipsi
    end if
  end subroutine energy_jacobian_edges

  !> energy_jacobian_edges for n triples at once (the same k_b and eta_b),
  !> lane i from its edges e1(i, :) = x_q - x_p, e2(i, :) = x_r - x_q and
  !> their rates de(i, 1:3), de(i, 4:6) (T v9): ke(i, :, :), ce(i, :, :),
  !> ok(i) as energy_jacobian_edges gives them, up to round-off. Written
  !> for the compiler to vectorise over the lanes (one loop of scalar
  !> work, small loops unrolled, degenerate lanes computed on harmless
  !> values and zeroed): the assembly takes a row of triples at a time.
  !> Hess psi is spelled out here as in hess_psi: called, it was neither
  !> inlined nor vectorised.
  !> The damping terms are always formed (they vanish with eta_b = 0).
  pure subroutine energy_jacobian_lanes(n, ld, k_b, eta_b, e1, e2, de, gauss_newton, ke, ce, ok)
    integer, intent(in) :: n              ! lanes 1..n of arrays of leading dimension ld >= n
    integer, intent(in) :: ld
    real(rp), intent(in) :: k_b, eta_b    ! [energy], [energy*time]
    real(rp), intent(in) :: e1(ld, 3), e2(ld, 3)  ! [length]
    real(rp), intent(in) :: de(ld, 6)     ! [length/time]
    logical, intent(in) :: gauss_newton
    real(rp), intent(inout) :: ke(ld, 6, 6)  ! [force/length] (lanes 1..n set)
    real(rp), intent(inout) :: ce(ld, 6, 6)  ! [force*time/length] (lanes 1..n set)
    logical, intent(inout) :: ok(ld)
    real(rp) :: a(3), b(3), dl(6), l1, l2, ipsi, il1, il2, r12, r21, kb(3), gpsi(6), je(3, 6)
    real(rp) :: kbdot(3), lam(3), e1h(3), e2h(3), hpd(6), dpsi, ae(3, 6), gs(6), sv, hs(6, 6), full, keep, jtj
    real(rp) :: a1, a2, ejae
    real(rp) :: psi, z(3)                 ! (work of lane_geometry.inc)
    integer :: i, p, q, c

    full = merge(0.0_rp, 1.0_rp, gauss_newton)
    !GCC$ ivdep
    do i = 1, n
      include 'lane_geometry.inc'
      ! kbdot = Je dl, lambda = k_b kb + eta_b kbdot
      !GCC$ unroll 3
      do c = 1, 3
        kbdot(c) = je(c, 1)*dl(1) + je(c, 2)*dl(2) + je(c, 3)*dl(3) + je(c, 4)*dl(4) + je(c, 5)*dl(5) + je(c, 6)*dl(6)
        lam(c) = k_b*kb(c) + eta_b*kbdot(c)
        e1h(c) = a(c)*il1
        e2h(c) = b(c)*il2
      end do
      r12 = l2*il1
      r21 = l1*il2
      ! (Hess psi) dl and dpsi = gpsi.dl
      a1 = e1h(1)*dl(1) + e1h(2)*dl(2) + e1h(3)*dl(3)
      a2 = e2h(1)*dl(4) + e2h(2)*dl(5) + e2h(3)*dl(6)
      dpsi = 0.0_rp
      !GCC$ unroll 3
      do c = 1, 3
        hpd(c) = r12*(dl(c) - a1*e1h(c)) + a2*e1h(c) + dl(c + 3)
        hpd(c + 3) = r21*(dl(c + 3) - a2*e2h(c)) + a1*e2h(c) + dl(c)
        dpsi = dpsi + gpsi(c)*dl(c) + gpsi(c + 3)*dl(c + 3)
      end do
      ! A_e = d Je[dl]: rows (Hess kb_c dl)^T
      ae(1, 1) = 0.0_rp;         ae(1, 2) = 2.0_rp*dl(6);  ae(1, 3) = -2.0_rp*dl(5)
      ae(2, 1) = -2.0_rp*dl(6);  ae(2, 2) = 0.0_rp;        ae(2, 3) = 2.0_rp*dl(4)
      ae(3, 1) = 2.0_rp*dl(5);   ae(3, 2) = -2.0_rp*dl(4); ae(3, 3) = 0.0_rp
      ae(1, 4) = 0.0_rp;         ae(1, 5) = -2.0_rp*dl(3); ae(1, 6) = 2.0_rp*dl(2)
      ae(2, 4) = 2.0_rp*dl(3);   ae(2, 5) = 0.0_rp;        ae(2, 6) = -2.0_rp*dl(1)
      ae(3, 4) = -2.0_rp*dl(2);  ae(3, 5) = 2.0_rp*dl(1);  ae(3, 6) = 0.0_rp
      !GCC$ unroll 6
      do q = 1, 6
        !GCC$ unroll 3
        do c = 1, 3
          ae(c, q) = (ae(c, q) - dpsi*je(c, q) - kbdot(c)*gpsi(q) - kb(c)*hpd(q))*ipsi
        end do
      end do
      ! weighted Hessian sum_c lambda_c Hess kb_c
      sv = lam(1)*kb(1) + lam(2)*kb(2) + lam(3)*kb(3)
      !GCC$ unroll 6
      do q = 1, 6
        gs(q) = lam(1)*je(1, q) + lam(2)*je(2, q) + lam(3)*je(3, q)
      end do
      ! Hs is symmetric: its upper triangle only, each entry used for both
      !GCC$ unroll 3
      do q = 1, 3
        !GCC$ unroll 3
        do p = 1, q
          hs(p, q) = -r12*e1h(p)*e1h(q)
          hs(p + 3, q + 3) = -r21*e2h(p)*e2h(q)
        end do
        !GCC$ unroll 3
        do p = 1, 3
          hs(p, q + 3) = e1h(p)*e2h(q)
        end do
        hs(q, q) = hs(q, q) + r12
        hs(q + 3, q + 3) = hs(q + 3, q + 3) + r21
        hs(q, q + 3) = hs(q, q + 3) + 1.0_rp
      end do
      !GCC$ unroll 6
      do q = 1, 6
        !GCC$ unroll 6
        do p = 1, q
          hs(p, q) = -sv*hs(p, q) - gs(p)*gpsi(q) - gpsi(p)*gs(q)
        end do
      end do
      ! Hess(lambda.z): block (1,2) = -2 [lambda]x (its mirror (2,1) the same by symmetry)
      hs(1, 5) = hs(1, 5) + 2.0_rp*lam(3);  hs(1, 6) = hs(1, 6) - 2.0_rp*lam(2)
      hs(2, 4) = hs(2, 4) - 2.0_rp*lam(3);  hs(2, 6) = hs(2, 6) + 2.0_rp*lam(1)
      hs(3, 4) = hs(3, 4) + 2.0_rp*lam(2);  hs(3, 5) = hs(3, 5) - 2.0_rp*lam(1)
      !GCC$ unroll 6
      do q = 1, 6
        !GCC$ unroll 6
        do p = 1, q
          jtj = je(1, p)*je(1, q) + je(2, p)*je(2, q) + je(3, p)*je(3, q)
          ejae = je(1, p)*ae(1, q) + je(2, p)*ae(2, q) + je(3, p)*ae(3, q)
          ke(i, p, q) = keep*(-k_b*jtj - full*(eta_b*ejae + hs(p, q)*ipsi))
          ce(i, p, q) = keep*(-eta_b*jtj)
          if (p /= q) then
            ejae = je(1, q)*ae(1, p) + je(2, q)*ae(2, p) + je(3, q)*ae(3, p)
            ke(i, q, p) = keep*(-k_b*jtj - full*(eta_b*ejae + hs(p, q)*ipsi))
            ce(i, q, p) = keep*(-eta_b*jtj)
          end if
        end do
      end do
    end do
  end subroutine energy_jacobian_lanes

  !> Bending energy 1/2 k_b |kb|^2; 0 for a degenerate triple.
  pure function energy_bend_energy(k_b, x9) result(w)
    real(rp), intent(in) :: k_b, x9(9)
    real(rp) :: w                          ! [energy]
    real(rp) :: e1(3), e2(3), l1, l2, psi, kb(3), gpsi(6), je(3,6)
    logical :: ok

    call edge_state(x9, e1, e2, l1, l2, psi, kb, gpsi, je, ok)
    w = 0.0_rp
    if (ok) w = 0.5_rp*k_b*dot_product(kb, kb)
  end function energy_bend_energy

  !> Dissipated power eta_b |J v|^2 (= 2R); 0 for a degenerate triple.
  pure function energy_power(eta_b, x9, v9) result(pw)
    real(rp), intent(in) :: eta_b, x9(9), v9(9)
    real(rp) :: pw                         ! [energy/time]
    real(rp) :: e1(3), e2(3), l1, l2, psi, kb(3), gpsi(6), je(3,6), dl(6), kbdot(3)
    logical :: ok

    call edge_state(x9, e1, e2, l1, l2, psi, kb, gpsi, je, ok)
    pw = 0.0_rp
    if (.not. ok) return
    call edge_rate(v9, dl)
    kbdot = matmul(je, dl)
    pw = eta_b*dot_product(kbdot, kbdot)
  end function energy_power

  !> energy_power for n triples at once (the same eta_b), from their edges
  !> and edge rates as energy_force_lanes takes them: pw(i) = eta_b |J v|^2
  !> of lane i (0 for a degenerate triple, ok(i) false), up to round-off.
  !> Vectorised over the lanes as energy_force_lanes.
  pure subroutine energy_power_lanes(n, ld, eta_b, e1, e2, de, pw, ok)
    integer, intent(in) :: n              ! lanes 1..n of arrays of leading dimension ld >= n
    integer, intent(in) :: ld
    real(rp), intent(in) :: eta_b         ! [energy*time]
    real(rp), intent(in) :: e1(ld, 3), e2(ld, 3)  ! [length]
    real(rp), intent(in) :: de(ld, 6)     ! [length/time]
    real(rp), intent(inout) :: pw(ld)     ! [energy/time] (lanes 1..n set)
    ! whether lane i's triple is not degenerate (lanes 1..n set); an
    ! argument, as the other lane kernels', not a local: sized by ld, gfortran
    ! allocated it on the heap at every call (some 9000 mallocs a step at 257 x 257)
    logical, intent(inout) :: ok(ld)
    real(rp) :: a(3), b(3), dl(6), l1, l2, ipsi, il1, il2, kb(3), gpsi(6), je(3, 6), kbdot(3), keep
    real(rp) :: psi, z(3)                 ! (work of lane_geometry.inc)
    integer :: i, q, c

    !GCC$ ivdep
    do i = 1, n
      include 'lane_geometry.inc'
      !GCC$ unroll 3
      do c = 1, 3
        kbdot(c) = je(c, 1)*dl(1) + je(c, 2)*dl(2) + je(c, 3)*dl(3) + je(c, 4)*dl(4) + je(c, 5)*dl(5) + je(c, 6)*dl(6)
      end do
      pw(i) = keep*eta_b*(kbdot(1)*kbdot(1) + kbdot(2)*kbdot(2) + kbdot(3)*kbdot(3))
    end do
  end subroutine energy_power_lanes

  ! Edges, lengths, psi, kb, grad psi (6) and Je = d kb/d(e1, e2) (3x6).
  ! ok = .false. for a zero edge or 1 + cos(theta) <= FOLD_TOL; nothing is
  ! divided then (outputs other than ok are zero).
  pure subroutine edge_state(x9, e1, e2, l1, l2, psi, kb, gpsi, je, ok)
    real(rp), intent(in) :: x9(9)
    real(rp), intent(out) :: e1(3), e2(3), l1, l2, psi, kb(3), gpsi(6), je(3,6)
    logical, intent(out) :: ok
    real(rp) :: z(3), ipsi, il1, il2
    integer :: j

    e1 = x9(4:6) - x9(1:3)
    e2 = x9(7:9) - x9(4:6)
    ! (not norm2: gfortran's guards against overflow with a division per
    ! component; edges of a cloth are nowhere near 1e154, and below
    ! EDGE_ABS a triple is degenerate anyway)
    l1 = sqrt(dot_product(e1, e1))
    l2 = sqrt(dot_product(e2, e2))
    psi = 0.0_rp
    kb = 0.0_rp
    gpsi = 0.0_rp
    je = 0.0_rp
    ok = min(l1, l2) > max(EDGE_REL*max(l1, l2), EDGE_ABS)
    if (.not. ok) return
    psi = l1*l2 + dot_product(e1, e2)
    ! psi/(l1 l2) = 1 + cos(theta); by the lengths one at a time (no
    ! overflow), as products with their reciprocals (divisions were a good
    ! part of this routine, called for every triple in every assembly).
    il1 = 1.0_rp/l1
    il2 = 1.0_rp/l2
    if ((psi*il1)*il2 <= FOLD_TOL) then
      ok = .false.
      psi = 0.0_rp
      return
    end if
    z(1) = e1(2)*e2(3) - e1(3)*e2(2)
    z(2) = e1(3)*e2(1) - e1(1)*e2(3)
    z(3) = e1(1)*e2(2) - e1(2)*e2(1)
    ipsi = 1.0_rp/psi
    kb = (2.0_rp*ipsi)*z
    gpsi(1:3) = (l2*il1)*e1 + e2
    gpsi(4:6) = (l1*il2)*e2 + e1
    ! d z/d e1 = -[e2]x, d z/d e2 = [e1]x; d kb = (2 dz - kb dpsi)/psi.
    je(:,1:3) = -2.0_rp*skew(e2)
    je(:,4:6) = 2.0_rp*skew(e1)
    do j = 1, 6
      je(:,j) = (je(:,j) - kb*gpsi(j))*ipsi
    end do
  end subroutine edge_state

  ! Hessian of psi = l1 l2 + e1.e2 in (e1, e2):
  ! [[l2/l1 Q1, I + e1h e2h^T], [I + e2h e1h^T, l1/l2 Q2]], Qi = I - eih eih^T.
  pure subroutine hess_psi(e1h, e2h, l1, l2, h)
    real(rp), intent(in) :: e1h(3), e2h(3), l1, l2
    real(rp), intent(out) :: h(6,6)
    real(rp) :: r12, r21
    integer :: i, j

    r12 = l2/l1
    r21 = l1/l2
    do j = 1, 3
      do i = 1, 3
        h(i,j) = -r12*e1h(i)*e1h(j)
        h(i+3,j+3) = -r21*e2h(i)*e2h(j)
        h(i,j+3) = e1h(i)*e2h(j)
        h(i+3,j) = e2h(i)*e1h(j)
      end do
      h(j,j) = h(j,j) + r12
      h(j+3,j+3) = h(j+3,j+3) + r21
      h(j,j+3) = h(j,j+3) + 1.0_rp
      h(j+3,j) = h(j+3,j) + 1.0_rp
    end do
  end subroutine hess_psi

  ! (Hessian of psi) times an edge-space vector d, without forming the matrix.
  pure subroutine hess_psi_times(e1h, e2h, l1, l2, d, hd)
    real(rp), intent(in) :: e1h(3), e2h(3), l1, l2, d(6)
    real(rp), intent(out) :: hd(6)
    real(rp) :: a1, a2

    a1 = dot_product(e1h, d(1:3))
    a2 = dot_product(e2h, d(4:6))
    hd(1:3) = (l2/l1)*(d(1:3) - a1*e1h) + a2*e1h + d(4:6)
    hd(4:6) = (l1/l2)*(d(4:6) - a2*e2h) + a1*e2h + d(1:3)
  end subroutine hess_psi_times

  ! Edge rates (de1/dt, de2/dt) = T v9.
  pure subroutine edge_rate(v9, d)
    real(rp), intent(in) :: v9(9)
    real(rp), intent(out) :: d(6)
    d(1:3) = v9(4:6) - v9(1:3)
    d(4:6) = v9(7:9) - v9(4:6)
  end subroutine edge_rate

  ! Node vector T^T g of an edge-space covector g (6 -> 9).
  pure subroutine edge_to_nodes_vec(g, f9)
    real(rp), intent(in) :: g(6)
    real(rp), intent(out) :: f9(9)
    f9(1:3) = -g(1:3)
    f9(4:6) = g(1:3) - g(4:6)
    f9(7:9) = g(4:6)
  end subroutine edge_to_nodes_vec

  ! Node matrix T^T M T of an edge-space matrix M (6x6 -> 9x9).
  pure subroutine edge_to_nodes_mat(m, k9)
    real(rp), intent(in) :: m(6,6)
    real(rp), intent(out) :: k9(9,9)
    real(rp) :: r(9,6)                     ! T^T M, rows by node

    r(1:3,:) = -m(1:3,:)
    r(4:6,:) = m(1:3,:) - m(4:6,:)
    r(7:9,:) = m(4:6,:)
    k9(:,1:3) = -r(:,1:3)
    k9(:,4:6) = r(:,1:3) - r(:,4:6)
    k9(:,7:9) = r(:,4:6)
  end subroutine edge_to_nodes_mat

  ! Cross-product matrix: skew(a) b = a x b.
  pure function skew(a) result(s)
    real(rp), intent(in) :: a(3)
    real(rp) :: s(3,3)
    s(1,1) = 0.0_rp;  s(1,2) = -a(3);  s(1,3) = a(2)
    s(2,1) = a(3);    s(2,2) = 0.0_rp; s(2,3) = -a(1)
    s(3,1) = -a(2);   s(3,2) = a(1);   s(3,3) = 0.0_rp
  end function skew

end module bending_energy
