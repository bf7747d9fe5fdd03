//! Identification of a field model from data (SPEC §1.6): the difference Gram of the
//! multiple-root fit, lagged products (sample autocovariances), the whitening operator and
//! the χ² tests of residual whiteness (also the trackers' gates).

mod chi_squared;
mod difference_gram;
mod lag_products;
mod whitening;

pub use chi_squared::{chi_squared_quantile, chi_squared_sf};
pub use difference_gram::{difference_gram, DifferenceGram, MAX_DIFFERENCE_ORDER};
pub use lag_products::{lag_products, LagProducts};
pub use whitening::whiten_axis;
