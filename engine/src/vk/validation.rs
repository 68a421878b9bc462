//! Validation messages: the debug-utils callback collects warnings and errors (INFO and VERBOSE
//! are left out), and [`ValidationLog`] hands them to tests and tools.

use std::ffi::{c_void, CStr};
use std::sync::{Arc, Mutex};

use ash::vk;

use super::device::Device;

/// Severity of a collected validation message (INFO and VERBOSE are not collected).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Severity {
    Warning,
    Error,
}

/// One message of the validation layer (or the loader) at warning or error severity.
#[derive(Clone, Debug)]
pub struct ValidationMessage {
    pub severity: Severity,
    pub id: String,
    pub text: String,
}

impl std::fmt::Display for ValidationMessage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "[{:?}] {}: {}", self.severity, self.id, self.text)
    }
}

/// Shared access to the collected validation messages.
#[derive(Clone)]
pub struct ValidationLog(
    pub(super) Arc<Mutex<Vec<ValidationMessage>>>,
    pub(super) std::sync::Weak<Device>,
);

impl ValidationLog {
    /// Whether the device still exists: after the context is dropped, `true` means some
    /// resource (which holds the device) outlived it, i.e. a leak.
    pub fn device_alive(&self) -> bool {
        self.1.strong_count() > 0
    }

    /// Takes the messages collected so far.
    pub fn take(&self) -> Vec<ValidationMessage> {
        std::mem::take(&mut *self.0.lock().unwrap_or_else(|e| e.into_inner()))
    }
}

/// Where the messenger's callback puts what it collects: handed to the messenger as its user data.
pub(crate) struct MessageSink {
    pub(crate) messages: Arc<Mutex<Vec<ValidationMessage>>>,
    /// Also print each message to stderr as it arrives.
    pub(crate) echo: bool,
}

impl MessageSink {
    pub(crate) fn lock(&self) -> std::sync::MutexGuard<'_, Vec<ValidationMessage>> {
        self.messages.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// The debug-utils callback of every messenger we install (our own instance's, and the one
/// `interop::wgpu` puts on the instance it creates for wgpu); `user` must point to a
/// [`MessageSink`] that outlives the messenger.
pub(crate) unsafe extern "system" fn on_validation_message(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: `user` is a `MessageSink` alive until the messenger is destroyed (the caller's
    // contract: `Context::headless` boxes it in the context, `interop::wgpu` in the instance's drop
    // callback); `data` is valid for the duration of the callback (Vulkan spec).
    let (sink, data) = unsafe { (&*(user as *const MessageSink), &*data) };
    // SAFETY: the strings are null or NUL-terminated for the duration of the callback.
    let text = |s: Option<&CStr>| {
        s.map(|c| c.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    // SAFETY: as above.
    let (id, body) = unsafe {
        (
            text(data.message_id_name_as_c_str()),
            text(data.message_as_c_str()),
        )
    };
    let severity = if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        Severity::Error
    } else {
        Severity::Warning
    };
    let message = ValidationMessage {
        severity,
        id,
        text: body,
    };
    if sink.echo {
        eprintln!("validation: {message}");
    }
    sink.lock().push(message);
    vk::FALSE
}
