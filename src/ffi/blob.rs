//! Cell blobs: parsing a blob in place and describing its cells.

use core::ffi::{c_char, c_void};

use super::convert::{detailed, out_ptr, read_ref, reparse, write_opt};
use super::result::{fault, invalid, FfiResult};
use super::types::{WeftBlob, WeftCellInfo};
use super::{WeftErrorDetail, WeftResult, BLOB_COOKIE};

/// Validates a cell blob in place (structure, checksum, every number; O(size)) and describes it
/// in `*out_blob`. Nothing is copied: `data` must stay valid and unchanged while the blob or
/// any world made with it is used.
///
/// - `data`: the blob's bytes (e.g. a file read into memory), `WEFT_BLOB_ALIGN`-aligned.
/// - `size`: bytes at `data`.
/// - `out_blob`: written on success.
/// - `out_detail`: NULL, or filled on every call with where a failure is (`BLOB_*` results).
///
/// # Safety
/// `data` is readable for `size` bytes; `out_blob` and a non-NULL `out_detail` are writable.
#[no_mangle]
pub unsafe extern "C" fn weft_blob_parse(
    data: *const c_void,
    size: usize,
    out_blob: *mut WeftBlob,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let run = || -> FfiResult<()> {
        let out = out_ptr(out_blob, c"out_blob")?;
        let mut b = WeftBlob {
            data,
            size,
            version: 0,
            cell_count: 0,
            internal_cookie: BLOB_COOKIE,
            reserved: 0,
        };
        // SAFETY: readability of data[..size] is the caller's contract.
        let blob = unsafe { reparse(&b) }?;
        b.version = blob.version();
        b.cell_count = u32::try_from(blob.cell_count()).map_err(|_| invalid(c"cell count"))?;
        // SAFETY: checked non-null and aligned; writable per the contract.
        unsafe { out.write(b) };
        Ok(())
    };
    let r = run();
    let detail = match r {
        Ok(()) => WeftErrorDetail::of(WeftResult::Ok),
        Err(d) => d,
    };
    // SAFETY: NULL or writable per the contract.
    unsafe { write_opt(out_detail, detail) };
    detail.result
}

/// Describes cell `cell` of a parsed blob in `*out_info` (validates the blob again: O(size)).
///
/// # Safety
/// `blob` points to a `WeftBlob` filled by `weft_blob_parse` whose bytes are still valid;
/// `out_info` is writable.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_blob_cell_info(
    blob: *const WeftBlob,
    cell: u32,
    out_info: *mut WeftCellInfo,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let r: FfiResult<()> = {
        (|| {
            // SAFETY: readable per the contract.
            let b = unsafe { read_ref(blob, c"blob") }?;
            let out = out_ptr(out_info, c"out_info")?;
            // SAFETY: the bytes are valid per the contract.
            let parsed = unsafe { reparse(b) }?;
            let c = parsed
                .cell(cell as usize)
                .ok_or(fault(WeftResult::BlobCellOutOfRange).cell(cell))?;
            let mut name = [0 as c_char; 64];
            for (d, s) in name.iter_mut().zip(c.name.bytes().take(63)) {
                *d = s as c_char;
            }
            let info = WeftCellInfo {
                name,
                width: c.width(),
                height: c.height(),
                cols: c.cols,
                rows: c.rows,
                refine: c.refine,
                node_count: u32::try_from(c.nodes.len()).unwrap_or(u32::MAX),
                stiffness: c.stiffness,
                density: c.density,
                bending: c.bending,
            };
            // SAFETY: checked non-null and aligned; writable per the contract.
            unsafe { out.write(info) };
            Ok(())
        })()
    };
    // SAFETY: a non-NULL `out_detail` is writable (the contract).
    unsafe { detailed(out_detail, r) }
}
