!> Element erosion, the FEM baseline of Hu et al. 2013 (section 3.3.4): an element
!> whose largest principal strain exceeds a limit (1.5 there) is deleted and
!> its mass stays on the nodes of the neighbouring elements. Here each
!> deleted element leaves a third of its mass on each of its nodes while
!> that node still belongs to a remaining element; a node left without
!> elements is removed. The internal energy of deleted elements and the
!> mass, momentum and kinetic energy of removed nodes are booked
!> (erosion_t), so mass, momentum and energy balances stay closed.
module fsph_erosion
  use fsph_kinds, only: wp
  use fsph_state, only: erosion_t, element_set_t, node_set_t, particle_set_t, coupling_t, contact_t
  use fsph_remesh, only: remove_elements, remove_unused_nodes, mesh_changed
  use fsph_arrays, only: reserve
  implicit none
  private

  public :: erode_elements, principal_strains, principal_log_strain

contains

  !> Largest principal logarithmic strain of a triangle of an
  !> axisymmetric body [-]: ln of the largest principal stretch, from the
  !> in-plane deformation gradient F = [x_j - x_i, x_m - x_i] [X_j - X_i,
  !> X_m - X_i]^-1 (the stretches are the square roots of the eigenvalues
  !> of F^T F) and the hoop stretch rbar/rbar0 of the centroid.
  pure function principal_log_strain(xe, x0e) result(strain)
    real(wp), intent(in) :: xe(2, 3)   !< current node positions (r, z) [m]
    real(wp), intent(in) :: x0e(2, 3)  !< initial node positions [m]
    real(wp) :: strain
    real(wp) :: a(2, 2), a0(2, 2), a0inv(2, 2), f(2, 2), c11, c22, c12, half_trace, det0, lam2, hoop
    a(:, 1) = xe(:, 2) - xe(:, 1)
    a(:, 2) = xe(:, 3) - xe(:, 1)
    a0(:, 1) = x0e(:, 2) - x0e(:, 1)
    a0(:, 2) = x0e(:, 3) - x0e(:, 1)
    det0 = a0(1, 1)*a0(2, 2) - a0(1, 2)*a0(2, 1)
    a0inv(1, 1) = a0(2, 2)/det0
    a0inv(2, 2) = a0(1, 1)/det0
    a0inv(1, 2) = -a0(1, 2)/det0
    a0inv(2, 1) = -a0(2, 1)/det0
    f = matmul(a, a0inv)
    c11 = f(1, 1)**2 + f(2, 1)**2
    c22 = f(1, 2)**2 + f(2, 2)**2
    c12 = f(1, 1)*f(1, 2) + f(2, 1)*f(2, 2)
    half_trace = 0.5_wp*(c11 + c22)
    lam2 = half_trace + sqrt(max(0.25_wp*(c11 - c22)**2 + c12**2, 0.0_wp))
    hoop = sum(xe(1, :))/sum(x0e(1, :))
    strain = log(max(sqrt(lam2), hoop))
  end function principal_log_strain

  !> Largest principal logarithmic strain of every element [-].
  subroutine principal_strains(ne, nn, conn, x, x0, strain)
    integer, intent(in) :: ne, nn, conn(3, ne)
    real(wp), intent(in) :: x(2, nn), x0(2, nn)
    real(wp), intent(out) :: strain(ne)
    integer :: ie
    !$omp parallel do default(none) shared(ne, conn, x, x0, strain) private(ie)
    do ie = 1, ne
      strain(ie) = principal_log_strain(x(:, conn(:, ie)), x0(:, conn(:, ie)))
    end do
    !$omp end parallel do
  end subroutine principal_strains

  !> Delete the elements at or beyond the strain limit (after the stress
  !> update of the cycle), book what leaves, renumber, rebuild the corner
  !> map and the contact surfaces. Returns the number of elements deleted.
  subroutine erode_elements(er, el, nd, pt, cp, ct, continuum_of_body, n_eroded)
    type(erosion_t), intent(inout) :: er
    type(element_set_t), intent(inout) :: el
    type(node_set_t), intent(inout) :: nd
    type(particle_set_t), intent(inout) :: pt
    type(coupling_t), intent(inout) :: cp
    type(contact_t), intent(inout) :: ct
    integer, intent(in) :: continuum_of_body(:)
    integer, intent(out) :: n_eroded
    logical, allocatable :: erode(:), keep_node(:)
    integer :: ie, a, k
    integer, allocatable :: new_index(:)
    n_eroded = 0
    if (.not. er%enabled .or. el%n == 0) return
    ! the strains in a work array that only grows; the deletion mask only
    ! when an element goes
    call reserve(er%strain, el%n)
    call principal_strains(el%n, nd%n, el%conn, nd%x, nd%x0, er%strain)
    n_eroded = count(er%strain(1:el%n) >= er%strain_limit)
    if (n_eroded == 0) return
    erode = er%strain(1:el%n) >= er%strain_limit
    do ie = 1, el%n
      if (.not. erode(ie)) cycle
      do k = 1, 3
        a = el%conn(k, ie)
        nd%mass_eroded(a) = nd%mass_eroded(a) + el%mass(ie)/3.0_wp
      end do
      er%element_mass = er%element_mass + el%mass(ie)
      er%internal = er%internal + el%mass(ie)*el%e(ie)
    end do
    call remove_elements(el, nd%n, erode, keep_node)
    do a = 1, nd%n
      if (keep_node(a)) cycle
      er%node_mass = er%node_mass + nd%mass(a)
      er%kinetic = er%kinetic + 0.5_wp*nd%mass(a)*(nd%v(1, a)**2 + nd%v(2, a)**2)
      er%momentum = er%momentum + nd%mass(a)*nd%v(:, a)
    end do
    call remove_unused_nodes(nd, el, pt, cp, keep_node, new_index)
    call mesh_changed(nd, el, ct, pt, continuum_of_body)
    er%n_eroded = er%n_eroded + n_eroded
  end subroutine erode_elements

end module fsph_erosion
