!> SPH smoothing kernel: the cubic B-spline of Monaghan & Lattanzio (1985)
!> with support 2h and the 2D (planar) normalisation 10/(7 pi h^2), so that
!> the integral of W over the plane is 1 (as in Xiao et al. 2012 section 1).
module fsph_kernel
  use fsph_kinds, only: wp, pi
  implicit none
  private

  !> 2D normalisation constant of the cubic B-spline [-] (times 1/h^2).
  real(wp), parameter, public :: kernel_norm_2d = 10.0_wp/(7.0_wp*pi)
  !> Support radius in units of h [-].
  real(wp), parameter, public :: kernel_support = 2.0_wp

  public :: kernel_w, kernel_shape, kernel_dwdr, kernel_gradient_factor, in_support

contains

  !> W(dist, h) [1/m^2].
  pure elemental function kernel_w(dist, h) result(w)
    real(wp), intent(in) :: dist   !< distance between the points [m]
    real(wp), intent(in) :: h      !< smoothing length [m]
    real(wp) :: w, q
    q = dist/h
    if (q < 1.0_wp) then
      w = 1.0_wp - 1.5_wp*q*q + 0.75_wp*q*q*q
    else if (q < 2.0_wp) then
      w = 0.25_wp*(2.0_wp - q)**3
    else
      w = 0.0_wp
    end if
    w = w*kernel_norm_2d/(h*h)
  end function kernel_w

  !> Shape of the spline, W(q h, h) h^2/kernel_norm_2d at q = dist/h [-]
  !> (1 at q = 0, 0 from q = 2).
  pure elemental function kernel_shape(q) result(w)
    real(wp), intent(in) :: q
    real(wp) :: w
    w = merge(1.0_wp - 1.5_wp*q*q + 0.75_wp*q*q*q, 0.25_wp*max(2.0_wp - q, 0.0_wp)**3, q < 1.0_wp)
  end function kernel_shape

  !> dW/d(dist) [1/m^3]; the gradient with respect to x_i of W(|x_i - x_j|)
  !> is kernel_dwdr * (x_i - x_j)/dist.
  pure elemental function kernel_dwdr(dist, h) result(dw)
    real(wp), intent(in) :: dist, h
    real(wp) :: dw, q
    q = dist/h
    if (q < 1.0_wp) then
      dw = -3.0_wp*q + 2.25_wp*q*q
    else if (q < 2.0_wp) then
      dw = -0.75_wp*(2.0_wp - q)**2
    else
      dw = 0.0_wp
    end if
    dw = dw*kernel_norm_2d/(h*h*h)
  end function kernel_dwdr

  !> Gradient factor F = (dW/d dist)/dist [1/m^4] of a pair at squared
  !> distance dist2 > 0 [m^2] with 1/h given [1/m]: grad_i W(|x_i - x_j|, h)
  !> = F (x_i - x_j). Written as a selection of the spline's two branches;
  !> gfortran 12 compiles it into a branch on q < 1 with the division in
  !> the outer arm all the same (a selection made arithmetic, with no
  !> branch, was measured no faster in the default case:
  !> docs/performance.md). Beyond the support max(2 - q, 0) makes the
  !> outer branch zero. (1/h comes from the caller: its division does not
  !> wait for the square root. Deriving 1/h and 1/q from one reciprocal of
  !> dist h made the pair loops slower, as that reciprocal must wait for
  !> it.)
  pure elemental function kernel_gradient_factor(dist2, inv_h) result(f)
    real(wp), intent(in) :: dist2, inv_h
    real(wp) :: f, q, inv_h2
    inv_h2 = inv_h*inv_h
    q = sqrt(dist2)*inv_h
    f = merge(-3.0_wp + 2.25_wp*q, -0.75_wp*max(2.0_wp - q, 0.0_wp)**2/q, q < 1.0_wp) &
        *kernel_norm_2d*inv_h2*inv_h2
  end function kernel_gradient_factor

  !> Whether a pair at squared distance dist2 [m^2] with smoothing lengths
  !> hi, hj [m] lies within the kernel support 2 h_ij, h_ij = (hi + hj)/2:
  !> the one test, with the same rounding, that the neighbour search
  !> applies (its reach per particle is kernel_support h/2), so that a pair
  !> counts or not by the same bits whether it was listed with a skin or
  !> not (the spline's own cut-off q < 2 can round the other way).
  pure elemental logical function in_support(dist2, hi, hj)
    real(wp), intent(in) :: dist2, hi, hj
    in_support = dist2 < (0.5_wp*kernel_support*hi + 0.5_wp*kernel_support*hj)**2
  end function in_support

end module fsph_kernel
