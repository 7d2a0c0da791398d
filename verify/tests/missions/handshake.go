// D2 takes off once D1 is up; both land once D2 has taken its photo.
package Handshake

var D1 Quadcopter
var D2 Quadcopter

func PAR_Main() {
	SEQ_One()
	SEQ_Two()
}

func SEQ_One() {
	D1.Arm()
	D1.Takeoff(1)
	Signal("up")
	Await("photo")
	D1.Land()
}

func SEQ_Two() {
	Await("up")
	D2.Arm()
	D2.Takeoff(1)
	D2.TakePhoto()
	Signal("photo")
	D2.Land()
}
