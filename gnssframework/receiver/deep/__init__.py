"""Deep integration: NCO aiding, the aided-tracking harness, its measurements, navigators, strapdown INS and the
loose-coupling baseline (Cai and Guo 2017)."""
