//! The dynamic loader (`dlopen`/`dlsym` of the C library), enough to load the model library once and
//! keep it for the life of the process.

use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::os::unix::ffi::OsStrExt;
use std::path::Path;

const RTLD_NOW: c_int = 2;

extern "C" {
    fn dlopen(filename: *const c_char, flags: c_int) -> *mut c_void;
    fn dlsym(handle: *mut c_void, symbol: *const c_char) -> *mut c_void;
    fn dlerror() -> *mut c_char;
}

/// A loaded shared library; never unloaded (models may live until the process ends).
pub(crate) struct Library {
    handle: *mut c_void,
}

// SAFETY: the handle is only passed to `dlsym`, which is thread-safe.
unsafe impl Send for Library {}
// SAFETY: as above.
unsafe impl Sync for Library {}

/// The loader's message about the last failure.
fn last_error() -> String {
    // SAFETY: dlerror returns null or a NUL-terminated string valid until the next dl call.
    let message = unsafe { dlerror() };
    if message.is_null() {
        "unknown error".into()
    } else {
        // SAFETY: checked non-null above.
        unsafe { CStr::from_ptr(message) }
            .to_string_lossy()
            .into_owned()
    }
}

impl Library {
    /// Loads `path` with every symbol resolved now.
    pub(crate) fn open(path: &Path) -> Result<Library, String> {
        let name = CString::new(path.as_os_str().as_bytes())
            .map_err(|_| format!("{}: a NUL byte in the path", path.display()))?;
        // SAFETY: `name` is a valid C string; loading runs the library's initialisers, which for
        // a Verilated model only set up static data.
        let handle = unsafe { dlopen(name.as_ptr(), RTLD_NOW) };
        if handle.is_null() {
            return Err(last_error());
        }
        Ok(Library { handle })
    }

    /// The address of `symbol`.
    ///
    /// # Safety
    /// `T` must be the function pointer type the library defines `symbol` with.
    pub(crate) unsafe fn function<T: Copy>(&self, symbol: &str) -> Result<T, String> {
        assert_eq!(
            std::mem::size_of::<T>(),
            std::mem::size_of::<*mut c_void>(),
            "a function pointer"
        );
        let name = CString::new(symbol).expect("symbol names have no NUL");
        // SAFETY: the handle is open and `name` a valid C string.
        let address = unsafe { dlsym(self.handle, name.as_ptr()) };
        if address.is_null() {
            return Err(format!("no symbol `{symbol}`: {}", last_error()));
        }
        // SAFETY: same size (asserted); the caller guarantees the type.
        Ok(unsafe { std::mem::transmute_copy::<*mut c_void, T>(&address) })
    }
}
