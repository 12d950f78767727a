//! The web editor's refusals and failures: an HTTP status and a message in plain words, sent as
//! `{"error": "…"}`. The library's errors keep their own messages; their kind picks the status.

use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde_json::json;

use crate::error::Error;

/// A refused or failed request: its status and a message in plain words.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ApiError {
    /// The HTTP status.
    pub status: StatusCode,
    /// What was wrong.
    pub message: String,
}

impl ApiError {
    /// 400: the request itself is malformed.
    pub fn bad_request(message: impl Into<String>) -> Self {
        ApiError {
            status: StatusCode::BAD_REQUEST,
            message: message.into(),
        }
    }

    /// 422: well formed, but not something the editor can do.
    pub fn unprocessable(message: impl Into<String>) -> Self {
        ApiError {
            status: StatusCode::UNPROCESSABLE_ENTITY,
            message: message.into(),
        }
    }

    /// 404: what it names does not exist.
    pub fn not_found(message: impl Into<String>) -> Self {
        ApiError {
            status: StatusCode::NOT_FOUND,
            message: message.into(),
        }
    }
}

/// The status for a library error: what the user asked for that cannot be done is 422 (a point
/// off the character) or 400 (a bad number); anything else is the server's fault, 500.
fn status_of(err: &Error) -> StatusCode {
    match err {
        Error::WithPath { err, .. } | Error::WithFrame { err, .. } | Error::WithKey { err, .. } | Error::WithPin { err, .. } => {
            status_of(err)
        }
        Error::Partial(errors) => errors
            .iter()
            .map(status_of)
            .max_by_key(|s| s.as_u16())
            .unwrap_or(StatusCode::INTERNAL_SERVER_ERROR),
        Error::OffCharacter { .. } => StatusCode::UNPROCESSABLE_ENTITY,
        // An output the editor may not write (someone else's folder, one in use): the state
        // on disk is in the way, not the request.
        Error::WouldOverwrite { .. } | Error::InUse { .. } => StatusCode::CONFLICT,
        // Image: a picture a page sent (an upload) that cannot be read.
        Error::Setting { .. } | Error::Mismatch { .. } | Error::Geometry { .. } | Error::Limit { .. } | Error::Image { .. } => {
            StatusCode::BAD_REQUEST
        }
        _ => StatusCode::INTERNAL_SERVER_ERROR,
    }
}

impl From<Error> for ApiError {
    fn from(err: Error) -> Self {
        ApiError {
            status: status_of(&err),
            message: err.to_string(),
        }
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        (self.status, Json(json!({ "error": self.message }))).into_response()
    }
}
