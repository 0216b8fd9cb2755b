//! The standard-scan measurement node (SCAN / FORCE_SCAN responses).

use super::{read_u16_le, write_all, RplidarError, RPLIDAR_NODE_LEN, RPLIDAR_Q6_PER_TURN};
use crate::angle::FineAngle;
#[cfg(test)]
use crate::wire::laser::turn_fraction;
use crate::wire::laser::turn_fraction_45ths;
use crate::wire::view;
use crate::wire::LaserReturn;

/// Whether five bytes pass a node's checks: S ≠ !S (byte 0 bits 0 and 1), C = 1 (byte 1
/// bit 0), and an angle below 360° (the document's range).
pub(super) fn node_is_valid(node: &[u8; RPLIDAR_NODE_LEN]) -> bool {
    let [b0, b1, b2, _, _] = *node;
    let flags_ok = (b0 ^ (b0 >> 1)) & 1 == 1;
    let check_ok = b1 & 1 == 1;
    let angle_q6 = (u32::from(b2) << 7) | u32::from(b1 >> 1);
    flags_ok && check_ok && angle_q6 < RPLIDAR_Q6_PER_TURN
}

view::fixed_view! {
    /// A zero-copy view over one 5-byte standard-scan node: a packet of one return.
    ///
    /// ```text
    /// byte 0: quality (bits 7..2) | !S (bit 1) | S (bit 0, a new revolution starts here)
    /// byte 1: angle_q6 bits 6..0 (bits 7..1) | C (bit 0, always 1)
    /// byte 2: angle_q6 bits 14..7
    /// bytes 3..5: distance_q2 (u16 LE; mm·4; 0 = no return)
    /// ```
    ///
    /// Made with [`RplidarNode::new_checked`], the buffer holds 5 bytes that pass the checks
    /// (S ≠ !S, C = 1, angle below 360°); the checks are weak, see the
    /// [module documentation](super). Made with [`RplidarNode::new_unchecked`], absent bytes read
    /// as 0.
    pub struct RplidarNode: RPLIDAR_NODE_LEN bytes, a "node",
        refused with RplidarError;

    /// Wraps a buffer after [`check_len`](Self::check_len) and
    /// [`check_bits`](Self::check_bits).
    ///
    /// # Errors
    /// [`RplidarError::Truncated`] or [`RplidarError::BadNode`].
    fn new_checked: check_bits;
}

impl<T: AsRef<[u8]>> RplidarNode<T> {
    /// Checks S ≠ !S, C = 1 and the angle range.
    ///
    /// # Errors
    /// [`RplidarError::Truncated`] for a short buffer, [`RplidarError::BadNode`].
    pub fn check_bits(&self) -> Result<(), RplidarError> {
        match self.buffer.as_ref().first_chunk::<RPLIDAR_NODE_LEN>() {
            None => Err(RplidarError::Truncated),
            Some(node) if node_is_valid(node) => Ok(()),
            Some(_) => Err(RplidarError::BadNode),
        }
    }

    /// The quality, 0..=63 (related to the reflected pulse strength).
    pub fn quality(&self) -> u8 {
        self.byte(0) >> 2
    }

    /// S: this node starts a new 360° scan.
    pub fn starts_revolution(&self) -> bool {
        self.byte(0) & 1 != 0
    }

    /// !S, the inverted start flag (a check bit).
    pub fn inverted_start_flag(&self) -> bool {
        self.byte(0) & 2 != 0
    }

    /// C, the check bit (always 1 in a valid node).
    pub fn check_bit(&self) -> bool {
        self.byte(1) & 1 != 0
    }

    /// The heading, degrees·64 (0..=32 767; below 23 040 in a valid node).
    pub fn angle_q6(&self) -> u16 {
        (u16::from(self.byte(2)) << 7) | u16::from(self.byte(1) >> 1)
    }

    /// The distance, mm·4 (0 = no return).
    pub fn distance_q2(&self) -> u16 {
        read_u16_le(self.buffer.as_ref(), 3).unwrap_or(0)
    }

    /// The heading as a fraction of a turn (angle_q6/64 degrees, exact to the LSB),
    /// clockwise seen from above.
    pub fn angle(&self) -> FineAngle {
        // A turn is 23 040 = 45·2⁹ units: turn_fraction(q6, 23 040) in 32-bit words.
        const _: () = assert!(RPLIDAR_Q6_PER_TURN as u64 == 45 << 9);
        turn_fraction_45ths(u32::from(self.angle_q6()), 23)
    }

    /// The node as a [`LaserReturn`]: the distance rounded to the millimetre (0 = no return;
    /// a distance below 0.5 mm reads as 0), the quality 0..=63.
    pub fn to_return(&self) -> LaserReturn {
        LaserReturn {
            angle: self.angle(),
            range_mm: (u32::from(self.distance_q2()) + 2) >> 2,
            quality: Some(self.quality()),
        }
    }

    /// The node's one return, as an iterator like the other packet views'.
    pub fn returns(&self) -> impl Iterator<Item = LaserReturn> {
        core::iter::once(self.to_return())
    }
}

/// The fields of one node, to [`emit`](RplidarNodeRepr::emit) or as parsed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RplidarNodeRepr {
    /// Quality, 0..=63.
    pub quality: u8,
    /// S: the node starts a new scan.
    pub start: bool,
    /// Heading, degrees·64 (0..=32 767; a sensor sends 0..23 040).
    pub angle_q6: u16,
    /// Distance, mm·4.
    pub distance_q2: u16,
}

impl RplidarNodeRepr {
    /// The fields of a node view.
    pub fn parse<T: AsRef<[u8]>>(node: &RplidarNode<T>) -> Self {
        Self {
            quality: node.quality(),
            start: node.starts_revolution(),
            angle_q6: node.angle_q6(),
            distance_q2: node.distance_q2(),
        }
    }

    /// Writes the 5 node bytes (S, !S and C set as they must be) to the front of `out`.
    ///
    /// # Errors
    /// [`RplidarError::OutOfRange`] for a quality above 63 or an angle above 32 767,
    /// [`RplidarError::BufferTooSmall`]; nothing is written then.
    pub fn emit(&self, out: &mut [u8]) -> Result<usize, RplidarError> {
        if self.quality > 63 || self.angle_q6 > 0x7FFF {
            return Err(RplidarError::OutOfRange);
        }
        let s = u8::from(self.start);
        let b0 = (self.quality << 2) | ((s ^ 1) << 1) | s;
        let [lo, hi] = ((self.angle_q6 << 1) | 1).to_le_bytes();
        let [d0, d1] = self.distance_q2.to_le_bytes();
        write_all(out, &[b0, lo, hi, d0, d1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_node_by_hand() {
        // Quality 15, S = 1: byte 0 = 15 << 2 | !S 0 << 1 | 1 = 0x3D.
        // 90.5° = 5 792 q6 = 0x16A0: byte 1 = (0x16A0 & 0x7F) << 1 | C = 0x20 << 1 | 1 = 0x41,
        // byte 2 = 0x16A0 >> 7 = 0x2D. 1 234.5 mm = 4 938 q2 = 0x134A: bytes 4A 13.
        let bytes = [0x3D, 0x41, 0x2D, 0x4A, 0x13];
        let n = RplidarNode::new_checked(&bytes[..]).unwrap();
        assert_eq!(n.quality(), 15);
        assert!(n.starts_revolution() && !n.inverted_start_flag() && n.check_bit());
        assert_eq!(n.angle_q6(), 5792);
        assert_eq!(n.distance_q2(), 4938);
        // 4 938/4 = 1 234.5 → rounds to 1 235 mm.
        let r = n.to_return();
        assert_eq!((r.range_mm, r.quality), (1235, Some(15)));
        assert_eq!(r.angle, turn_fraction(5792, 23_040));
        assert_eq!(n.returns().count(), 1);
        let repr = RplidarNodeRepr::parse(&n);
        assert_eq!(
            repr,
            RplidarNodeRepr {
                quality: 15,
                start: true,
                angle_q6: 5792,
                distance_q2: 4938
            }
        );
        let mut out = [0; 5];
        repr.emit(&mut out).unwrap();
        assert_eq!(out, bytes);
    }

    #[test]
    fn checks() {
        let good = [0x3E, 0x41, 0x2D, 0x4A, 0x13]; // S = 0, !S = 1
        assert!(RplidarNode::new_checked(&good[..]).is_ok());
        for bad in [
            [0x3F, 0x41, 0x2D, 0, 0], // S = !S = 1
            [0x3C, 0x41, 0x2D, 0, 0], // S = !S = 0
            [0x3E, 0x40, 0x2D, 0, 0], // C = 0
            [0x3E, 0x01, 0xB4, 0, 0], // 0xB4 << 7 = 23 040: 360°
        ] {
            assert_eq!(
                RplidarNode::new_checked(&bad[..]),
                Err(RplidarError::BadNode)
            );
        }
        // 359.98°: 23 039 = 0xB3 << 7 | 0x7F → bytes FF B3.
        assert!(RplidarNode::new_checked(&[0x3E, 0xFF, 0xB3, 0, 0][..]).is_ok());
        assert_eq!(
            RplidarNode::new_checked(&good[..4]),
            Err(RplidarError::Truncated)
        );
        let empty = RplidarNode::new_unchecked(&[][..]);
        assert_eq!(empty.check_bits(), Err(RplidarError::Truncated));
        assert_eq!(empty.to_return().range_mm, 0);
        let repr = RplidarNodeRepr {
            quality: 64,
            ..RplidarNodeRepr::default()
        };
        assert_eq!(repr.emit(&mut [0; 5]), Err(RplidarError::OutOfRange));
    }
}
