//! The echo service a worker runs for a calibration probe (`pvrsim
//! calibrate --network`): every data frame comes back with the same payload,
//! until the probe says goodbye.

use std::time::Duration;

use tokio::io::AsyncWriteExt;
use tokio::net::TcpStream;
use tokio::runtime::Runtime;

use crate::net::tcp::frame::{encode_frame, read_frame_async, LinkFrame};
use crate::net::tcp::TcpOptions;
use crate::net::{Envelope, NetError, NetResult};

/// Echoes frames on `s` until a goodbye or `opts.deadline * 10` of silence.
pub fn echo(rt: &Runtime, mut s: TcpStream, opts: &TcpOptions) -> NetResult<()> {
    let idle = opts.deadline * 10;
    rt.block_on(async {
        loop {
            match read_frame_async(&mut s, &opts.codec, Some(idle)).await? {
                Some(LinkFrame::Data(e)) => {
                    let back = Envelope {
                        from: e.to,
                        to: e.from,
                        kind: e.kind,
                        payload: e.payload,
                    };
                    let f = encode_frame(&opts.codec, &LinkFrame::Data(back))?;
                    s.write_all(&f).await.map_err(|e| NetError::Io {
                        what: "echoing to the probe".into(),
                        msg: e.to_string(),
                    })?;
                }
                Some(LinkFrame::Heartbeat) => {}
                Some(LinkFrame::Goodbye) | None => {
                    let _ = tokio::time::timeout(Duration::from_secs(1), s.shutdown()).await;
                    return Ok(());
                }
            }
        }
    })
}
